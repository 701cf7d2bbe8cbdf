"""``optdesign warm-up PROBLEM.yaml``: compile the problem's NLPs ahead of its first solve.

A solve that finds no compiled library of its NLP runs on CasADi's virtual machine and starts
the build beside it (:mod:`optdesign.solver.compiled`), and one that finds no compiled lanes
of the mechanism's kinematics runs them as NumPy statements and starts theirs
(:mod:`optdesign.numerics.native_lanes`); this command builds every admissible phase count's
NLP and both lanes (the kinematics, and the speeds the screening reads) now, as many at once
as there are cores, and prints where each library is (for a file with a ``pareto:`` section,
each count's NLP with the exact Hessian too, on which a front's warm-started points run, and
the NLP of each count's largest-ratio end). Exit 0 when every library is in place;
1 when one could not be built (no C compiler on PATH, no cache folder of the user's own, a
compiler that failed: solves then run on the virtual machine and the NumPy lanes, as
before); 2 for bad input (one line naming the file and key).
"""
from __future__ import annotations

import sys


def add_parser(sub) -> None:
    p = sub.add_parser("warm-up", help="compile the problem's NLP derivatives into the cache "
                                       "ahead of its first solve")
    p.add_argument("problem", help="problem file (YAML)")
    p.set_defaults(run=run)


def run(args) -> int:
    from optdesign.limits import local_processes
    from optdesign.problem.loader import load_problem
    from optdesign.solver import compiled

    problem = load_problem(args.problem)
    where = compiled.folder()
    if where is None:
        print("optdesign warm-up: no cache folder of this user's own "
              "(XDG_CACHE_HOME or ~/.cache): solves run on CasADi's virtual machine",
              file=sys.stderr)
        return 1
    if compiled.compiler() is None:
        print(f"optdesign warm-up: no C compiler ({compiled.COMPILER}) on PATH: solves run "
              f"on CasADi's virtual machine", file=sys.stderr)
        return 1
    nlps = nlps_to_compile(problem)
    labels, recipes = zip(*(_recipes(problem, nlps) + lanes_recipes_of(problem)))
    ok, built = True, []
    for label, (_, path, seconds, note) in zip(labels, compiled.warm_up(
            recipes, where, local_processes(problem.solver.workers))):
        built.append(path is not None)
        if path is None:
            ok = False
            print(f"{label}: not compiled ({note}): runs on CasADi's virtual machine")
        else:
            print(f"{label}: {path}" + (f" (compiled in {seconds:.1f} s)"
                                        if note == "compiled" else f" ({note})"))
    # each compiled NLP's record beside its library (optdesign.solver.nlp_memo), kept as its
    # IPOPT is made on the library (an NLP left on the virtual machine is not made here: its
    # derivatives' functions would take seconds to build)
    for (nlp, hessian, *_), on_library in zip(nlps, built):
        if on_library:
            nlp.solver(hessian)
    return 0 if ok else 1


def nlps_to_compile(problem) -> list[tuple]:
    """(NLP, Hessian, what it is) of every NLP warm-up compiles: each of :func:`nlps_of` with
    each of :func:`hessians_of`, and each of :func:`end_nlps_of` on the exact Hessian."""
    nominal = " (nominal)"
    return [(nlp, hessian, nominal if nlp.problem is not problem else "")
            for nlp in nlps_of(problem) for hessian in hessians_of(problem)] + \
        [(nlp, "exact", " (largest-ratio end)") for nlp in end_nlps_of(problem)]


def hessians_of(problem) -> list[str]:
    """The Hessians whose IPOPT the file's commands run: its ``solver.hessian``, and the
    exact one where it has a ``pareto:`` section (a front's warm-started points run on it:
    docs/pareto.md, "Warm starts")."""
    own = problem.solver.hessian
    return [own] + (["exact"] if problem.method.pareto is not None and own != "exact" else [])


def recipes_of(problem) -> list[tuple]:
    """(label, :class:`~optdesign.solver.compiled.Recipe`) of every NLP a solve of
    ``problem`` builds first (:func:`nlps_of`), with the problem's own Hessian."""
    return _recipes(problem, [(nlp, problem.solver.hessian) for nlp in nlps_of(problem)])


def _recipes(problem, nlps: list) -> list[tuple]:
    """(label, recipe) of each (NLP, Hessian) or (NLP, Hessian, what it is) of ``nlps``,
    ``problem``'s (:func:`nlps_of`; without a third, a robust solve's nominal NLP is so
    named)."""
    from optdesign.solver import compiled

    out = []
    for nlp, hessian, *what in nlps:
        what = what[0] if what else " (nominal)" if nlp.problem is not problem else ""
        out.append((f"{problem.model.count_variable} = {nlp.count}{what}"
                    + (" (exact Hessian)" if hessian != problem.solver.hessian else ""),
                    compiled.recipe(nlp.x_sym, nlp.p_sym, nlp.f, nlp.g, hessian)))
    return out


def nlps_of(problem) -> list:
    """The NLP a solve of ``problem`` builds first at every admissible count (and a robust
    solve's nominal one), with as many hand-over slots as the driver gives it for the file's
    own design: the process's own, kept (:mod:`optdesign.solver.built`), so asked twice they
    are built once."""
    from dataclasses import replace

    from optdesign.solver import verify
    from optdesign.solver.phase_solver import PhaseSolver
    from optdesign.solver.nlp import is_robust

    problems = [problem]
    if is_robust(problem):          # a robust solve polishes the nominal problem first
        problems.append(replace(problem, objective=replace(problem.objective, robust="none")))
    out = []
    for count in problem.counts():
        given = problem.start_values() | {problem.model.count_variable: count}
        for which in problems:
            out.append(PhaseSolver(which, count).nlp(
                verify(which, given, search=False).sequences))
    return out


def end_nlps_of(problem) -> list:
    """For a file with a ``pareto:`` section: the NLP of each swept count's largest-ratio end
    (its gain maximised, on the exact Hessian:
    :func:`optdesign.fronts.worker.largest_gain_problem`), with the hand-over slots of the
    file's own design; none for a file without one."""
    if problem.method.pareto is None:
        return []
    from optdesign.fronts.axis import with_axis
    from optdesign.fronts.worker import largest_gain_problem
    from optdesign.solver import verify
    from optdesign.solver.phase_solver import PhaseSolver

    ends = largest_gain_problem(with_axis(problem))
    out = []
    for count in list(problem.method.pareto.counts or problem.counts()):
        given = ends.start_values() | {ends.model.count_variable: count}
        out.append(PhaseSolver(ends, count).nlp(verify(ends, given, search=False).sequences))
    return out


def lanes_recipes_of(problem) -> list[tuple]:
    """(label, :class:`~optdesign.numerics.c_library.Recipe`) of the compiled lanes of every
    admissible count's kinematics (the exact evaluator's grids) and speeds (the screening)."""
    from optdesign.evaluation.design import Design
    from optdesign.numerics import native_lanes
    from optdesign.numerics.angle_lanes import lane_functions

    out = []
    for count in problem.counts():
        design = Design.from_problem(problem, {problem.model.count_variable: count})
        model, options = design.model, design.option_key
        speeds = model.speeds(count, options)
        # the kinematics' lanes run in stages cut at its atan2 (optdesign.numerics.angle_lanes)
        for what, functions in (("kinematics", lane_functions(model.kinematics(count, options))),
                                ("speeds", [(speeds, speeds.serialize())])):
            for k, (fn, text) in enumerate(functions):
                stage = f" (stage {k + 1} of {len(functions)})" if len(functions) > 1 else ""
                out.append((f"{problem.model.count_variable} = {count}, {what} lanes{stage}",
                            native_lanes.recipe(fn, text)))
    return out
