"""An NLP's record beside its compiled library (optdesign.solver.nlp_memo): made from it, the
NLP is the one its graph gives (the layout, what the build learns, its functions as CasADi
serialised them); a record is named by everything the graph is made from, and one that is
corrupt, or names a library that is gone, is passed over for the graph.

A record is used only where its library is intact: a stand-in library (bytes sealed with
the NLP's digest, never loaded here) lets these tests make and read records without a
compiler; tests/solve/test_compiled.py solves on a real one, with and without its record."""
import pytest

from optdesign.numerics import c_library, code_stamp, user_cache
from optdesign.problem.loader import problem_from_dict
from optdesign.quantities.criteria import constraints_of
from optdesign.solver import built, compiled, nlp_memo
from optdesign.solver.nlp import IPOPT_OPTIONS, PhaseNLP
from tests.conftest import ROOT, file_data

DISC = ROOT / "problems" / "sharkov2022_disc_interval.yaml"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv(compiled.VARIABLE, "load")
    built.forget()
    yield compiled.folder()
    built.forget()


def _with_record(problem, count: int) -> tuple[PhaseNLP, str]:
    """The NLP of ``count`` built from its graph, a stand-in library sealed with its digest
    and its record kept: (the NLP, the digest)."""
    nlp = PhaseNLP(problem, count)
    hessian = problem.solver.hessian
    digest = compiled.recipe(nlp.x_sym, nlp.p_sym, nlp.f, nlp.g, hessian).digest
    body = b"a stand-in library, never loaded"
    user_cache.write(compiled.folder() / f"{compiled.name_of(digest)}.so",
                     body + user_cache.trailer(c_library.TRAILER_TAGS["nlp"], digest, body))
    nlp._kept_as_record(hessian, digest)
    return nlp, digest


def _same(made: PhaseNLP, graph: PhaseNLP) -> None:
    assert made._record is not None and "x_sym" not in made.__dict__     # no graph built
    assert made.layout == graph.layout
    assert (made.n_x, made.n_g, made.n_p) == (graph.n_x, graph.n_g, graph.n_p)
    for name in ("_fill", "surrogate", "_candidates"):
        assert getattr(made, name).serialize() == getattr(graph, name).serialize()
    assert [(n, w, t, z) for n, _, w, t, z in made._picks] == \
        [(n, w, t, z) for n, _, w, t, z in graph._picks]
    assert [(n, c.name) for n, c in made._criterion_blocks] == \
        [(n, c.name) for n, c in graph._criterion_blocks]
    assert list(made._derived) == list(graph._derived)
    assert (made._tracked, made.turn) == (graph._tracked, graph.turn)


@pytest.mark.parametrize("name, count", [("sharkov2022_disc_interval", 6),
                                         ("vergov_solve", 5), ("spreader", 8),
                                         ("robust_fourbar", 4)])
def test_an_nlp_made_from_its_record_is_the_one_its_graph_gives(cache, name, count):
    """A regulation interval (eccentricity slots, tracked quantities), a slotted lever, a
    ratio band with a housing bound (picks of attained figures), a robust problem (its
    scenario parts' blocks)."""
    problem = problem_from_dict(file_data(ROOT / "problems" / f"{name}.yaml"))
    graph, _ = _with_record(problem, count)
    made = PhaseNLP(problem, count)
    _same(made, graph)
    # asked for its graph, it builds the same one
    assert made.g.numel() == graph.g.numel() and made._record is None
    assert made.layout == graph.layout
    assert made._fill.serialize() == graph._fill.serialize()


def test_a_record_is_named_by_what_the_graph_is_made_from(cache, monkeypatch):
    problem = problem_from_dict(file_data(DISC))
    criteria = constraints_of(problem)
    key = nlp_memo.key_of(problem, 6, 12, criteria, IPOPT_OPTIONS)
    assert key == nlp_memo.key_of(problem_from_dict(file_data(DISC)), 6, 12, criteria,
                                  IPOPT_OPTIONS)
    l3 = problem.design["l3"]
    wider = problem.with_bounds(l3=(l3.lower, 1.1 * l3.upper))
    others = [nlp_memo.key_of(problem, 6, 13, criteria, IPOPT_OPTIONS),
              nlp_memo.key_of(problem, 7, 12, criteria, IPOPT_OPTIONS),
              nlp_memo.key_of(wider, 6, 12, criteria, IPOPT_OPTIONS),
              nlp_memo.key_of(problem, 6, 12, criteria, IPOPT_OPTIONS | {"ipopt.max_cpu_time": 9.0})]
    monkeypatch.setattr(nlp_memo, "_environment", lambda: ("another package's files",))
    others.append(nlp_memo.key_of(problem, 6, 12, criteria, IPOPT_OPTIONS))
    assert key not in others and len(set(others)) == len(others)
    monkeypatch.setenv(compiled.VARIABLE, "off")
    assert nlp_memo.key_of(problem, 6, 12, criteria, IPOPT_OPTIONS) is None


def test_a_corrupt_record_or_one_whose_library_is_gone_is_passed_over(cache):
    problem = problem_from_dict(file_data(DISC))
    graph, digest = _with_record(problem, 6)
    [record] = list(cache.glob("nlp-record-*.json"))
    data = bytearray(record.read_bytes())
    data[len(data) // 2] ^= 1
    record.write_bytes(bytes(data))
    assert PhaseNLP(problem, 6)._record is None             # built from its graph
    graph, digest = _with_record(problem, 6)                # the record made again
    assert PhaseNLP(problem, 6)._record is not None
    (cache / f"{compiled.name_of(digest)}.so").unlink()     # the library gone
    made = PhaseNLP(problem, 6)
    assert made._record is None and made.layout == graph.layout


def test_records_written_long_ago_are_let_go_of_when_one_is_written(cache, monkeypatch):
    """Every change of the package's files names new records: one written more than
    KEPT_DAYS ago goes when another is written, and the oldest beyond KEPT_RECORDS (a link of
    that name is not followed)."""
    import os
    import time

    monkeypatch.setattr(nlp_memo, "KEPT_RECORDS", 3)
    older = []
    for k in range(3):                  # written 1, 2 and 3 days ago: the 3rd oldest is cut
        path = cache / (f"nlp-record-{k:040d}.json")
        path.write_text("{}")
        when = time.time() - (k + 1) * 86400
        os.utime(path, (when, when))
        older.append(path)

    old = cache / ("nlp-record-" + "c" * 40 + ".json")
    old.write_text("{}")
    recent = cache / ("nlp-record-" + "d" * 40 + ".json")
    recent.write_text("{}")
    outside = cache.parent / "outside.json"
    outside.write_text("kept")
    linked = cache / ("nlp-record-" + "e" * 40 + ".json")
    linked.symlink_to(outside)
    long_ago = time.time() - (nlp_memo.KEPT_DAYS + 1) * 86400
    os.utime(old, (long_ago, long_ago))
    os.utime(linked, (long_ago, long_ago), follow_symlinks=False)
    _with_record(problem_from_dict(file_data(DISC)), 6)
    assert not old.exists() and recent.exists()
    assert linked.is_symlink() and outside.read_text() == "kept"
    # kept: the new one, `recent` (now) and the newest of the older ones
    assert [p.exists() for p in older] == [True, False, False]


@pytest.mark.parametrize("change", [{"libraries": ["not", "a", "mapping"]},
                                    {"layout": None}, {"functions": {"fill": "not CasADi"}},
                                    {"n_x": 1}])
def test_a_sealed_record_that_does_not_read_as_one_is_passed_over(cache, change):
    """A record sealed as the cache seals its files but whose fields are not an NLP's (a
    record of a later format written under this one's name, say): the graph is built."""
    problem = problem_from_dict(file_data(DISC))
    graph, _ = _with_record(problem, 6)
    key = graph._record_key
    nlp_memo.write(key, nlp_memo.read(key) | change)
    made = PhaseNLP(problem, 6)
    assert made._record is None and made.layout == graph.layout


def test_the_records_names_change_with_any_file_of_the_package(tmp_path, monkeypatch):
    """The stamp of the package's files (path, modification time, size) names every record:
    a file changed in place, one added, or one in a subfolder changed names new records; the
    compiled bytecode's folder does not count."""
    import os

    package = tmp_path / "package"
    (package / "sub" / "__pycache__").mkdir(parents=True)
    (package / "a.py").write_text("x = 1\n")
    (package / "sub" / "b.py").write_text("y = 2\n")
    monkeypatch.setattr(code_stamp, "PACKAGE", package)

    def stamp():
        nlp_memo._environment.cache_clear()
        return nlp_memo._environment()[0]           # the files' stamp

    seen = [stamp()]
    (package / "sub" / "__pycache__" / "b.pyc").write_bytes(b"bytecode")
    assert stamp() == seen[0]
    st = os.stat(package / "a.py")
    (package / "a.py").write_text("x = 3\n")                    # the same size
    os.utime(package / "a.py", ns=(st.st_atime_ns, st.st_mtime_ns + 1))
    seen.append(stamp())
    (package / "sub" / "b.py").write_text("y = 22\n")
    seen.append(stamp())
    (package / "c.py").write_text("")
    seen.append(stamp())
    nlp_memo._environment.cache_clear()
    assert len(set(seen)) == 4
