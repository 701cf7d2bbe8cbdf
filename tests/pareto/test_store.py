"""The journal points.jsonl: whole lines only, a cut line dropped on resume."""
from optdesign.pareto.store import Journal


def test_journal_drops_a_cut_line_and_keeps_appending_whole_lines(tmp_path):
    j = Journal(tmp_path / "points.jsonl")
    assert j.start({"points": 3}, resume=False) == []
    j.append({"key": [4, 0], "delta": 0.1})
    with open(j.path, "a") as fh:
        fh.write('{"key": [4, 1], "del')                 # a kill in the middle of a write
    assert j.start({"points": 3}, resume=True) == [{"key": [4, 0], "delta": 0.1}]
    j.append({"key": [4, 1], "delta": 0.2})
    header, records = j.read()
    assert header == {"key": "run", "points": 3}
    assert records == [{"key": [4, 0], "delta": 0.1}, {"key": [4, 1], "delta": 0.2}]
