"""The journal points.jsonl: whole lines only, a cut line dropped on resume."""
from optdesign.fronts.store import Journal


def _rec(index, delta):
    """A record with every field a resumed journal checks (a failed point: no design)."""
    return {"key": [4, index], "count": 4, "kind": "sweep", "status": "failed",
            "feasible": False, "design": {}, "delta": delta, "ratio": None, "epsilon": None}


def test_journal_drops_a_cut_line_and_keeps_appending_whole_lines(tmp_path):
    j = Journal(tmp_path / "points.jsonl")
    assert j.start({"points": 3}, resume=False) == []
    j.append(_rec(0, 0.1))
    with open(j.path, "a") as fh:
        fh.write('{"key": [4, 1], "del')                 # a kill in the middle of a write
    assert j.start({"points": 3}, resume=True) == [_rec(0, 0.1)]
    j.append(_rec(1, 0.2))
    header, records = j.read()
    assert header == {"key": "run", "points": 3}
    assert records == [_rec(0, 0.1), _rec(1, 0.2)]
