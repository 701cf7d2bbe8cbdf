"""Repairs along a floor axis: a looser rule's cell is never left worse than its stricter
neighbour's (a design meeting the stricter rule meets the looser), and a repair that finds
nothing better leaves the cell as it was."""
from optdesign.atlas.run import better, looser_than_stricter
from optdesign.atlas.spec import atlas_from_dict
from tests.atlas.conftest import TINY


def _rec(cell, values, delta):
    return {"cell": cell, "values": values, "feasible": delta is not None, "delta": delta,
            "design": {"l0": float(cell)}}


def test_a_looser_cell_worse_than_its_stricter_neighbour_is_repaired():
    spec = atlas_from_dict(TINY, "tiny.yaml")
    cells = spec.cells()          # (4, 40), (4, 45), (6, 40), (6, 45)
    done = {c.index: _rec(c.index, spec.values_of(c), d)
            for c, d in zip(cells, [0.30, 0.28, 0.14, 0.15])}
    assert [(i, nb["cell"]) for i, nb in looser_than_stricter(spec, cells, done)] == [(0, 1)]
    done[2] = _rec(2, spec.values_of(cells[2]), None)        # no optimum under the looser
    assert [(i, nb["cell"]) for i, nb in looser_than_stricter(spec, cells, done)] == \
        [(0, 1), (2, 3)]


def test_a_repair_keeps_the_better_verified_optimum():
    old, worse, lower, none = (_rec(0, {}, d) for d in (0.2, 0.3, 0.1, None))
    assert better(old, worse) is old and better(old, lower) is lower
    assert better(old, none) is old and better(none, old) is old
    assert better(None, none) is none
