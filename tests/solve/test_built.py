"""NLPs kept for the process (optdesign.solver.built): a second solve of a problem builds
nothing and answers the same to the last bit; a problem that differs in anything the NLP is
built from (here a length's box) gets an NLP of its own."""
import pickle
from types import SimpleNamespace

import pytest

from optdesign import kept_children
from optdesign.evaluation import figures
from optdesign.numerics import heap
from optdesign.problem.loader import load_problem, problem_from_dict
from optdesign.solver import built, phase_solver, polishing, solve
from optdesign.solver.nlp import PhaseNLP
from optdesign.solver.screening import LineScreening
from tests.conftest import ROOT, file_data

VERGOV = ROOT / "problems" / "vergov_solve.yaml"


def answer(result) -> tuple:
    return (result.status, result.delta, result.ratio, result.design, result.iterations,
            [(p.count, p.status, p.delta, p.iterations) for p in result.per_phase])


@pytest.fixture
def fresh():
    built.forget()
    yield
    built.forget()


def test_a_second_solve_builds_nothing_and_answers_the_same(fresh, monkeypatch, tmp_path):
    """Each count's NLP built once, in this process: the polishes it forks (two at once on
    the disc problem) inherit it, and a second solve builds none."""
    log = tmp_path / "builds"

    def counted(*args):
        with open(log, "a") as f:           # from the forked polishes as well
            f.write(f"{args[1]}\n")
        return PhaseNLP(*args)

    def builds() -> list[int]:
        return [int(x) for x in log.read_text().split()] if log.exists() else []

    monkeypatch.setattr(phase_solver, "PhaseNLP", counted)
    disc = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    first = solve(disc)
    assert [p.screening["polished"] for p in first.per_phase] == [2]
    assert builds() == [6] and first.timings_s["build"] > 0.01
    again = solve(load_problem(ROOT / "problems" / "sharkov2022_disc.yaml"))  # loaded again
    assert builds() == [6] and again.timings_s["build"] < 1e-3
    assert answer(again) == answer(first)
    vergov = problem_from_dict(file_data(VERGOV))
    assert answer(solve(vergov)) == answer(solve(problem_from_dict(file_data(VERGOV))))
    assert builds() == [6, 5, 3]        # least promise first (solver/count_order.py)


def test_a_copy_sent_to_a_worker_has_the_same_key():
    """Pickled together with its count (as a front's point is sent to its worker), the copy's
    key is the key of the problem: the worker's next point finds the NLP its last one built."""
    for problem in (problem_from_dict(file_data(VERGOV)),
                    load_problem(ROOT / "problems" / "free_design.yaml")):
        job = (problem, 3, problem.start_values())
        copy, count, *_ = pickle.loads(pickle.dumps(job))
        assert built.key_of(copy, count) == built.key_of(problem, 3)
        again = pickle.loads(pickle.dumps(copy))
        assert built.key_of(again, 3) == built.key_of(problem, 3)


def test_another_box_gets_its_own_nlp(fresh):
    data = file_data(VERGOV)
    problem = problem_from_dict(data)
    data["design"]["XD"] = {"lower": 120, "upper": 500, "initial": 292}
    other = problem_from_dict(data)
    assert built.key_of(problem, 3) != built.key_of(other, 3)
    assert built.kept(problem, 3) is built.kept(problem_from_dict(file_data(VERGOV)), 3)
    solve(problem)
    after = solve(other)
    assert after.timings_s["build"] > 0
    built.forget()
    alone = solve(other)
    assert answer(after) == answer(alone)


def test_the_least_recently_used_are_let_go(fresh, monkeypatch):
    monkeypatch.setattr(built, "KEPT", 2)
    problem = problem_from_dict(file_data(VERGOV))
    first = built.kept(problem, 3)
    first[3] = nlp = SimpleNamespace(held_bytes=1000)       # (an NLP's stand-in)
    built.kept(problem, 5)
    built.kept(problem, 3)                      # used again: the count 5's goes first
    built.kept(problem, 7)
    assert built.kept(problem, 3) is first and first == {3: nlp}
    assert built.kept(problem, 5) == {}         # let go: an empty dict to fill anew


def test_the_kept_nlps_hold_at_most_their_bytes(fresh, monkeypatch):
    """NLPs that hold more than KEPT_BYTES together are let go, the least recently used
    first, and never the one asked for: each NLP holds what its build and its IPOPT's left
    allocated on the C heap."""
    if heap.in_use() is None:
        pytest.skip("no mallinfo2 here: nothing is weighed")
    problem = problem_from_dict(file_data(VERGOV))
    phase_solver.PhaseSolver(problem, 3).prepare()
    held = built.held_bytes()
    # its graph and IPOPT's functions on it: 1.19 MB in a process that built nothing before,
    # 0.94 to 1.06 MB after other builds (what CasADi keeps between them)
    assert held > 250_000
    monkeypatch.setattr(built, "KEPT_BYTES", held + 1)
    five = built.kept(problem, 5)
    five[1] = SimpleNamespace(held_bytes=1)     # (an NLP's stand-in): both fit, both kept
    assert len(built._kept) == 2
    five[1].held_bytes = 2                      # one byte too many: asked for, the count 5's
    assert built.kept(problem, 5) is five and list(built._kept.values()) == [five]
    monkeypatch.setattr(built, "KEPT_BYTES", 1)
    phase_solver.PhaseSolver(problem, 3).prepare()  # the count 5's let go as the 3's is asked for
    nlps = built.kept(problem, 3)               # alone, the one asked for is kept past the budget
    assert list(built._kept.values()) == [nlps] and nlps[6].held_bytes > 1_000_000


def test_a_criterion_added_to_the_mechanism_builds_another_nlp(fresh, monkeypatch):
    """Code, not the file: a constraint the mechanism's criteria gain in this process (as
    docs/architecture.md's worked example adds one) is not met by an NLP kept without it."""
    from optdesign.mechanisms import get_mechanism
    from optdesign.quantities.criteria import LengthConstraint

    problem = problem_from_dict(file_data(VERGOV))
    before = built.key_of(problem, 3)
    mech = get_mechanism(problem.mechanism)
    own = mech.criteria
    monkeypatch.setattr(mech, "criteria", lambda constraints, options: own(
        constraints, options) + [LengthConstraint("least_xd", lambda p: p["XD"], lower=1.0)])
    assert built.key_of(problem, 3) != before


def test_two_threads_never_share_an_nlp(fresh):
    """An NLP's IPOPT function and iteration watch serve one run at a time."""
    import threading

    problem = problem_from_dict(file_data(VERGOV))
    mine = built.kept(problem, 3)
    theirs = []
    thread = threading.Thread(target=lambda: theirs.append(built.kept(problem, 3)))
    thread.start()
    thread.join()
    assert theirs[0] is not mine and built.kept(problem, 3) is mine


def test_the_two_best_basins_are_polished_at_once_the_second_knowing_no_optimum(
        fresh, logged_polishes):
    """Two basins as if at once: with two workers, the first in the solving process and the
    second in a process forked beside it; with one, both here, one after the other. Either
    way the second is a secondary polish on a solver of its own that knows no optimum the
    first found (so it does not stop as it passes near it), and the answer is the same to the
    bit, each polish's record too."""
    two, polishes = logged_polishes("sharkov2022_disc", 2)
    one, in_turn = logged_polishes("sharkov2022_disc", 1)
    assert [r.per_phase[0].screening["polished"] for r in (two, one)] == [2, 2]
    # (process, secondary, optima known) of the first polish, then of the second
    assert [(p[0], p[2], p[3]) for p in in_turn] == [("here", "False", "0"),
                                                     ("here", "True", "0")]
    where = {p[1:]: p[0] for p in polishes}         # logged as they begin, in either order
    assert len(where) == 2 and [where.get(p[1:]) for p in in_turn] == ["here", "beside"]
    assert answer(two) == answer(one) and _records(two) == _records(one)
    assert two.timings_s["beside"] > 0 and one.timings_s["beside"] == 0


def test_a_polish_that_fails_here_ends_the_one_beside(fresh, monkeypatch):
    """The first basin's polish raises (a Ctrl-C, an error): the second's process, forked
    beside it, is ended, not left to compute on (and then to wait on its pipe)."""
    import multiprocessing

    def interrupted(self, values, ver=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(polishing.Polishing, "polish", interrupted)
    data = file_data(ROOT / "problems" / "sharkov2022_disc.yaml")
    data.setdefault("solver", {})["workers"] = 2
    forked = []
    head_beside = polishing._head_beside
    monkeypatch.setattr(polishing, "_head_beside",
                        lambda *a: forked.extend(head_beside(*a)) or forked)
    with pytest.raises(KeyboardInterrupt):
        solve(problem_from_dict(data))
    assert len(forked) == 1 and forked[0].child is None
    assert multiprocessing.active_children() == []


def _polishes_of(name: str, workers: int, log, monkeypatch) -> tuple:
    """The solve of problem ``name`` with ``workers``, and its polishes as logged: (process
    "here" or "beside", start, secondary, optima known) in the order they began."""
    import os

    data = file_data(ROOT / "problems" / f"{name}.yaml")
    data.setdefault("solver", {})["workers"] = workers
    log.unlink(missing_ok=True)
    result = solve(problem_from_dict(data))
    here = str(os.getpid())
    lines = [line.split(" ", 3) for line in log.read_text().splitlines()]
    return result, [("here" if pid == here else "beside", start, secondary, known)
                    for pid, secondary, known, start in lines]


@pytest.fixture
def logged_polishes(monkeypatch, tmp_path):
    import os

    log = tmp_path / "polishes"
    solve_from = phase_solver.PhaseSolver.solve_from

    def logged(self, values, *args, **kwargs):
        with open(log, "a") as f:
            f.write(f"{os.getpid()} {kwargs.get('secondary', False)} {len(self.avoid)} "
                    f"{sorted(values.items())}\n")
        return solve_from(self, values, *args, **kwargs)

    monkeypatch.setattr(phase_solver.PhaseSolver, "solve_from", logged)
    return lambda name, workers: _polishes_of(name, workers, log, monkeypatch)


def _records(result) -> list:
    return [(s.ipopt_status, s.iterations, s.delta, s.start, s.note)
            for p in result.per_phase for s in p.starts]


@pytest.fixture
def four_basins(monkeypatch):
    """The housing problem's second basin stalls infeasible, which no longer calls for more
    basins (``Polishing.apart``); counted as a sign of several basins, as it was, the solve
    polishes two further basins after the best two: the polishes beside that these tests
    follow."""
    from optdesign.solver.phase_solver import JOINED, SUCCESS

    monkeypatch.setattr(polishing.Polishing, "apart", lambda self: len(self.optima) > 1 or any(
        not r.feasible or r.ipopt_status not in SUCCESS + (JOINED,)
        for r in self.result.starts))


def test_a_further_basin_polished_beside_is_the_one_polished_in_turn(fresh, logged_polishes,
                                                                     four_basins):
    """The housing problem polishes four basins (:func:`four_basins`): the best two at once,
    then the third here with the fourth begun beside it, knowing the optimum the first found;
    the third finds no new one, so the fourth's outcome is taken. Every record is the
    one-worker solve's, to the bit, and the fourth basin was polished once, beside."""
    two, polishes = logged_polishes("housing_disc", 2)
    one, in_turn = logged_polishes("housing_disc", 1)
    assert answer(two) == answer(one) and _records(two) == _records(one)
    assert [p[0] for p in in_turn] == ["here"] * 4
    # the processes log as they begin, in either order: matched to the turn's by the start
    where = {p[1:]: p[0] for p in polishes}
    assert len(where) == len(polishes) == 4
    assert [where.get(p[1:]) for p in in_turn] == ["here", "beside", "here", "beside"]
    assert two.timings_s["beside"] > 0


def test_a_further_basin_begun_with_stale_knowledge_is_polished_again_here(
        fresh, logged_polishes, four_basins, monkeypatch):
    """Where the polish here changes what the next one would know (here forced: every
    check finds the knowledge changed), the polish begun beside is dropped and the next
    basin polished here: the same records as in turn."""
    import itertools

    ticks = itertools.count()
    monkeypatch.setattr(polishing.Polishing, "_known", lambda self: next(ticks))
    two, polishes = logged_polishes("housing_disc", 2)
    one, in_turn = logged_polishes("housing_disc", 1)
    assert answer(two) == answer(one) and _records(two) == _records(one)
    # the first, then (the second beside) the third and the fourth here, in this order
    assert [p[1:] for p in polishes if p[0] == "here"] == [in_turn[k][1:] for k in (0, 2, 3)]


def test_a_wait_for_a_polish_beside_makes_what_the_solve_asks_for_later(
        fresh, logged_polishes, monkeypatch):
    """While the solving process waits for a polish beside it (here: every wait, as long as
    there is something to make), it screens the lines through the best optimum so far (a
    line at a time), refines it for the accuracy record and finds its quantities; the later
    steps find them made (on the housing problem the first polish's optimum stays the best).
    Every record, the accuracy record and the answer are the one-worker solve's, to the
    bit."""
    from optdesign import kept_children, lifetime

    made = []
    while_waiting = polishing.Polishing._while_waiting

    def logged(self, *args):
        for piece in while_waiting(self, *args):
            made.append(piece.func.__name__)
            yield piece

    def refined(*args, **kwargs):
        if "n_grid" in kwargs:       # a refinement, not a check
            calls.append("refined")
        return exact_figures(*args, **kwargs)

    def lines_screened(self, end):
        calls.extend(("line row", self.through, row) for row in range(self.screened, end))
        return screen_rows(self, end)

    calls = []
    exact_figures, screen_rows = figures.exact_figures, LineScreening._screen
    monkeypatch.setattr(lifetime.Beside, "ready", lambda self: False)
    monkeypatch.setattr(kept_children.Kept, "ready", lambda self: False)
    monkeypatch.setattr(polishing.Polishing, "_while_waiting", logged)
    monkeypatch.setattr(LineScreening, "_screen", lines_screened)
    monkeypatch.setattr(figures, "exact_figures", refined)
    figures.forget()
    two, _ = logged_polishes("housing_disc", 2)
    assert {"_line_step", "_refined", "_quantities_ahead"} <= set(made)
    made_ahead, calls = calls, []
    figures.forget()
    one, _ = logged_polishes("housing_disc", 1)
    assert answer(two) == answer(one) and _records(two) == _records(one)
    assert two.accuracy == one.accuracy
    assert [p.quantities for p in two.per_phase] == [p.quantities for p in one.per_phase]
    # made once, ahead (the lines one at a time): no row of a line screening nor a
    # refinement was made twice for one design
    assert made_ahead == calls and "line row" in {c[0] for c in calls if c != "refined"}


def test_the_first_line_polish_made_in_a_wait_is_the_one_made_in_turn(fresh, monkeypatch):
    """The disc problem at 12 phases polishes a further basin beside and then a line through
    its best optimum: the line polish is made while this process waits for the basin's
    (nothing else to make then), and taken, as the further basin leaves what the solve
    knows as it was (here every wait made as long as what it can make). Every record and the answer are the one-worker solve's, to the bit,
    and those of the solve that makes it again in turn (here forced: none taken), as where
    the solve knows more by then."""
    taken = []
    taken_ahead = polishing.Polishing._taken_ahead

    def logged(self, values):
        made = taken_ahead(self, values)
        taken.append(made is not None)
        return made

    monkeypatch.setattr(polishing.Polishing, "_taken_ahead", logged)
    # every wait long enough to make all it can (else a race with the polish beside)
    monkeypatch.setattr(kept_children.Kept, "ready", lambda self: False)
    data = file_data(ROOT / "problems" / "sharkov2022_disc.yaml", design__phases=12)
    data.setdefault("solver", {})["workers"] = 2
    two = solve(problem_from_dict(data))
    assert taken[:1] == [True]
    monkeypatch.setattr(polishing.Polishing, "_taken_ahead", lambda self, values: None)
    again = solve(problem_from_dict(data))
    data["solver"]["workers"] = 1
    one = solve(problem_from_dict(data))
    assert answer(two) == answer(one) == answer(again)
    assert _records(two) == _records(one) == _records(again)


def test_the_files_own_design_is_checked_beside_once_its_polish_is_done(
        fresh, logged_polishes, monkeypatch):
    """The process beside the first polish checks the file's own design as it is once its
    own polish is done, and this process reads that check (on the disc problem no polish
    starts from it: in turn it is checked here). The answer and every record are the
    one-worker solve's, to the bit."""
    import os

    here = os.getpid()
    evaluate_at = figures._evaluate_at

    def checked(design, *args):
        if os.getpid() == here:
            evaluated.add(tuple(sorted(design.values.items())))
        return evaluate_at(design, *args)

    evaluated = set()
    monkeypatch.setattr(figures, "_evaluate_at", checked)
    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    own = tuple(sorted(problem.start_values().items()))
    figures.forget()
    two, _ = logged_polishes("sharkov2022_disc", 2)
    checked_here, evaluated = evaluated, set()
    figures.forget()
    one, _ = logged_polishes("sharkov2022_disc", 1)
    assert answer(two) == answer(one) and _records(two) == _records(one)
    assert own in evaluated and own not in checked_here


def test_a_second_solve_polishes_beside_in_the_kept_child_and_answers_the_same(
        fresh, logged_polishes):
    """A second solve of a problem in one process asks its polish beside of the child the
    first solve forked (optdesign.kept_children: it holds the count's NLP), which forks
    nothing more and gives the records the one-worker solve gives, to the bit."""
    import multiprocessing

    first, polishes = logged_polishes("housing_disc", 2)
    children = {c.pid for c in multiprocessing.active_children()}
    again, polished_again = logged_polishes("housing_disc", 2)
    one, _ = logged_polishes("housing_disc", 1)
    assert len(children) == 1 and {c.pid for c in multiprocessing.active_children()} == children
    assert "beside" in {p[0] for p in polished_again}
    assert _records(first) == _records(again) == _records(one)
    assert answer(first) == answer(again) == answer(one)


@pytest.fixture
def records_logged(monkeypatch, tmp_path):
    """A file each sensitivity record's process writes its pid to (the kept child's as
    well), no record made at any count yet, and no wait for a polish beside making any
    piece ahead (the quantities are found in ``_fill``)."""
    import os

    from optdesign.evaluation import sensitivity

    log = tmp_path / "sensitivities"
    real = sensitivity.sensitivities

    def logged(*args, **kwargs):
        with open(log, "a") as f:               # from the kept child as well
            f.write(f"{os.getpid()}\n")
        return real(*args, **kwargs)

    monkeypatch.setattr(sensitivity, "sensitivities", logged)
    monkeypatch.setattr(sensitivity, "_MADE", set())
    monkeypatch.setattr(kept_children.Kept, "ready", lambda self: True)   # no wait makes any
    return log


def test_the_answers_sensitivities_are_made_beside_while_its_quantities_are_found_here(
        fresh, records_logged):
    """A count solved alone: its answer's sensitivity record, the first this process makes
    at the count, is made by the kept child its polish beside ran in, while this process
    finds the answer's quantities (here no wait for a polish beside made them ahead): the
    record of the one-worker solve, which makes it here, to the bit."""
    import os

    log = records_logged
    data = file_data(ROOT / "problems" / "sharkov2022_disc.yaml")
    data.setdefault("solver", {})["workers"] = 2
    two = solve(problem_from_dict(data))
    made_by = log.read_text().split()
    log.unlink()
    data["solver"]["workers"] = 1
    one = solve(problem_from_dict(data))
    assert len(made_by) == 1 and made_by[0] != str(os.getpid())
    assert log.read_text().split() == [str(os.getpid())]
    assert two.per_phase[0].sensitivities == one.per_phase[0].sensitivities
    assert two.per_phase[0].sensitivities["d_delta_d_length_per_mm"]


def test_a_later_record_is_asked_of_the_child_that_built_for_one(fresh, records_logged):
    """With the quantities to find here (no wait made them ahead), a record is asked of the
    kept child: any where this process has built none (the chains' gradient functions),
    else only one that made a record before (a child that never made one is not asked).
    Each is the one-worker solve's record, to the bit."""
    import os

    from optdesign.evaluation import sensitivity

    log = records_logged
    data = file_data(ROOT / "problems" / "sharkov2022_disc.yaml")
    data.setdefault("solver", {})["workers"] = 2
    problem = problem_from_dict(data)
    first = solve(problem)                      # none built here: asked beside
    here = sensitivity.sensitivity_record(problem, first.per_phase[0].design)
    again = solve(problem)                      # built in both: asked beside
    kept_children.end_all()
    fresh_child = solve(problem)                # a child that never made one: made here
    made_by = log.read_text().split()
    data["solver"]["workers"] = 1
    kept_children.end_all()
    one = solve(problem_from_dict(data))
    me = str(os.getpid())
    assert len(made_by) == 4
    assert made_by[1] == made_by[3] == me and made_by[0] == made_by[2] != me
    records = [r.per_phase[0].sensitivities for r in (first, again, fresh_child, one)]
    assert records[0]["d_delta_d_length_per_mm"]
    assert all(r == records[-1] for r in records) and here == records[-1]


def test_a_sensitivity_record_not_made_beside_is_made_here(fresh, monkeypatch):
    """Where the child's answer is an error (a record that did not come back), the solving
    process makes the record itself: the one-worker solve's."""
    from optdesign.evaluation import sensitivity
    from optdesign.solver import driver

    class Failed:
        def __call__(self):
            raise RuntimeError("no value from a kept child")

        def cancel(self):
            pass

    monkeypatch.setattr(sensitivity, "_MADE", set())
    monkeypatch.setattr(driver, "answer_record_beside", lambda *args, **kwargs: Failed())
    data = file_data(ROOT / "problems" / "sharkov2022_disc.yaml")
    data.setdefault("solver", {})["workers"] = 2
    two = solve(problem_from_dict(data))
    data["solver"]["workers"] = 1
    one = solve(problem_from_dict(data))
    assert two.per_phase[0].sensitivities == one.per_phase[0].sensitivities
    assert two.per_phase[0].sensitivities["d_delta_d_length_per_mm"]
