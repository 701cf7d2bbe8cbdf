"""``optdesign atlas`` run locally on a 2 × 2 atlas: the cells equal the disc problem's optima
(δ does not depend on the scale), a warm-started cell equals its cold solve, the files."""
import json
import subprocess
import sys

import pytest

from optdesign.atlas.spec import load_atlas
from optdesign.atlas.worker import solve_cell
from tests.conftest import ROOT
from tests.test_units import unlisted

#: the disc problem's optima at n = 4 and 6 (docs/benchmarks.md, solve_scaling: 0.252056, 0.140205), whose
#: box and pin radius this atlas holds relative to the 20 mm crank; the exact evaluator's δ,
#: reproduced to 1e-8 (IPOPT's tolerance on the active constraints, well above rounding)
DISC = {(4, 40): 0.2520563428, (6, 40): 0.1402049196}


def test_a_two_by_two_atlas_holds_the_disc_problems_optima(tiny_atlas):
    out, frame = tiny_atlas
    assert len(frame) == 4 and (frame["status"] == "optimal").all()
    for (n, rule), delta in DISC.items():
        row = frame[(frame["phases"] == n) & (frame["min_transmission_angle_deg"] == rule)]
        assert row["delta"].item() == pytest.approx(delta, rel=1e-8)
        assert row["l1"].item() == 1.0 and row["pin_radius"].item() >= 6.25 - 1e-8
    # a stricter rule costs ripple at every count
    for n in (4, 6):
        mine = frame[frame["phases"] == n].set_index("min_transmission_angle_deg")["delta"]
        assert mine[45] > mine[40]
    assert frame["binding"].str.contains("transmission_angle").all()
    doc = json.loads((out / "atlas.json").read_text())
    assert doc["relative_to"] == "l1" and doc["n_feasible"] == 4
    assert doc["axes"] == {"phases": [4, 6], "min_transmission_angle_deg": [40, 45]}
    assert doc["units"]["l0"].startswith("- (length / the regulated length l1")
    assert {"delta", "ratio", "pin_radius", "time_s", "cell"} <= set(doc["units"])
    assert unlisted(doc) == set() and list(doc)[-2:] == ["schema_version", "units"]
    for name in ("atlas_counts.png", "atlas_map.png", "atlas.html", "cells.jsonl"):
        assert (out / name).stat().st_size > 1000


def test_a_warm_started_cell_agrees_with_a_cold_solve(tiny_atlas, tiny_path):
    """The n = 6 cells were screened with their n = 4 neighbours' optima; solved cold they
    give the same δ to 1e-6."""
    out, frame = tiny_atlas
    spec = load_atlas(tiny_path)
    records = [json.loads(line) for line in (out / "cells.jsonl").read_text().splitlines()[1:]]
    warm = next(r for r in records if r["neighbours"] > 0)
    cell = spec.cells()[warm["cell"]]
    cold = solve_cell(spec.problem(cell), cell.index, spec.values_of(cell), [])
    assert cold["neighbours"] == 0 and cold["status"] == "optimal"
    assert cold["delta"] == pytest.approx(warm["delta"], abs=1e-6)


def test_the_command_stays_light_until_it_runs():
    code = ("import sys, optdesign.commands.atlas; from optdesign.cli import build_parser; "
            "build_parser(); print(sorted(m for m in ('pandas', 'matplotlib', 'dask', "
            "'optdesign.atlas.run') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, check=True)
    assert out.stdout.strip() == "[]"


def test_the_charts_drawn_beside_the_command_are_the_ones_drawn_here(tiny_atlas, tiny_path,
                                                                      tmp_path):
    """The command hands its two charts to the figures' process (as pickled jobs: one that
    does not pickle would be drawn in the command instead, slowly and silently); what that
    process draws is what write_charts draws in this one, pixel for pixel."""
    import pickle
    import shutil

    import numpy as np
    from PIL import Image

    from optdesign.atlas.charts import chart_jobs, write_charts
    from optdesign.atlas.run import run_atlas
    from optdesign.atlas.spec import load_atlas

    out, _ = tiny_atlas
    again = tmp_path / "again"
    shutil.copytree(out, again)                 # the journal: every cell resumed, re-verified
    result = run_atlas(load_atlas(tiny_path), again, workers=1, resume=True, progress=False)
    jobs = pickle.loads(pickle.dumps(chart_jobs(result, tmp_path)))
    assert [args[-1].name for _, args in jobs] == ["atlas_counts.png", "atlas_map.png"]
    for beside, here in zip(sorted(out.glob("atlas_*.png")), write_charts(result, tmp_path)):
        assert beside.name == here.name
        assert np.array_equal(np.asarray(Image.open(beside)), np.asarray(Image.open(here)))
