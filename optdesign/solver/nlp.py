"""The NLP of one phase count, built once: free lengths (scaled to O(1)) -> least ripple.

Speeds are per unit crank speed, f_c(φ) = s·dθ_k/dφ for each curve c = (stroke sign s,
rocker k) (Sharkov & Kalinin 2022, eqs. 5-8; docs/formulation.md). For each eccentricity e the
NLP carries

* ``w_hi`` (ω_max/ω1): one stationary point φ_m,c per curve with ``f_c'(φ_m,c) = 0`` and
  ``w_hi - f_c(φ_m,c) >= 0``, so the peak is exact, not O(h²);
* ``w_lo`` (ω_min/ω1): ``M`` hand-over slots, each a free angle φ_x with
  ``f_a(φ_x) - w_lo >= 0`` and ``f_b(φ_x) - w_lo >= 0`` for the curves a, b the envelope hands
  over between. Maximising w_lo puts φ_x where min(f_a, f_b) peaks, i.e. at the crossing, whose
  value is the envelope's local minimum: exact and conservative, with no equality that can
  become infeasible. Minima inside a run are held by ``logsumexp_ρ(f(φ_j)) - w_lo >= 0`` at the
  samples (a conservative smooth maximum where no crossing is involved);
* the time mean: on the run of curve c between hand-overs u and v, ∫ f_c dφ = θ_c(v) - θ_c(u),
  so mean = Σ runs (θ_c(v) - θ_c(u))/2π. Any wrong boundary selects a lower curve, so the sum
  never exceeds the true mean (conservative for the ratio); it is exact at the crossings.

Built once. Which curves a slot hands over between is a *parameter* (one-hot selections of the
curves, an "active" flag and a "last" flag per slot), so a change of the hand-over order, a
new start, a tightened transmission-angle bound or a Pareto ε changes parameters and bounds,
never the graph; a sequence longer than ``M`` slots rebuilds with more slots (rare: ``M``
starts at the curve count, one hand-over into each). Every constraint's bounds come from its criterion
(:mod:`optdesign.quantities.criteria`) at each solve.

A regulation interval (``regulation: {eccentricity: {lower, upper}}``) adds
:func:`eccentricity_slots` eccentricity blocks whose e is a parameter (the regulated length × e
enters the kinematics): the driver holds the worst interior eccentricities of the exact check
there, like a hand-over, and moves them without rebuilding; an idle slot duplicates an end,
its variables fixed and its rows free (:class:`Held`). A quantity bounded (or minimised) over
the interval is tracked in every slot as at a listed eccentricity, and its epigraph covers the
held slots.

Construction (chosen by ``benchmarks/solve_scaling.py``): the mechanism's per-angle SX
function and a per-sample SX function (cos²μ and the smooth maximum) are ``map``-ped over the
samples and points inside an MX graph; CasADi differentiates the mapped functions as mapped
derivatives, so the build costs one chain's derivatives, not N·n of them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from optdesign.envelope.sampled import STROKE_SIGNS, ripple_of
from optdesign.evaluation.figures import eccentricities_of
from optdesign.numerics import heap
from optdesign.quantities import get_quantity
from optdesign.quantities.criteria import (constraints_of, interval_quantities, objective_of,
                                           spec_forms, spec_sides,
                                           quantity_specs)
from optdesign.solver import compiled, nlp_memo
from optdesign.solver.screening import iterations_of

IPOPT_OPTIONS = {
    "ipopt.print_level": 0,
    "ipopt.tol": 1e-9,
    "ipopt.acceptable_tol": 1e-6,
    "ipopt.mu_strategy": "adaptive",
    "ipopt.nlp_scaling_method": "gradient-based",
    "ipopt.sb": "yes",
    "ipopt.bound_relax_factor": 0.0,          # bounds are the designer's: keep them exactly
    "ipopt.constr_viol_tol": 1e-8,
    "print_time": False,
}

#: IPOPT's options for a run warm-started from a neighbour's optimum (its primal-dual
#: solution: a front's point polished from the point beside it): the barrier starts at the
#: final μ of a cold run and stays monotone, and the start is left where it lies, so the
#: exact Hessian's Newton steps converge in a few iterations where a cold start is pushed
#: off its active bounds and walks back (IPOPT's ``warm_start_*`` options;
#: ``docs/pareto.md``, "Warm starts")
WARM_OPTIONS = {
    "ipopt.warm_start_init_point": "yes",
    "ipopt.mu_strategy": "monotone",
    "ipopt.mu_init": 1e-11,
    "ipopt.tol": 1e-10,     # a tenth of a cold run's: a warm optimum is a cold one's to 1e-11
    "ipopt.warm_start_bound_push": 1e-9,
    "ipopt.warm_start_bound_frac": 1e-9,
    "ipopt.warm_start_slack_bound_push": 1e-9,
    "ipopt.warm_start_slack_bound_frac": 1e-9,
    "ipopt.warm_start_mult_bound_push": 1e-9,
}


@dataclass
class Block:
    """A named slice of the decision or constraint vector."""

    name: str
    start: int
    size: int

    @property
    def slice(self) -> slice:
        return slice(self.start, self.start + self.size)


@dataclass
class Layout:
    """Where each quantity sits in x, g and p, so results and bindings can be read by name."""

    x: list[Block] = field(default_factory=list)
    g: list[Block] = field(default_factory=list)
    p: list[Block] = field(default_factory=list)

    def add(self, blocks: list[Block], name: str, size: int) -> slice:
        start = blocks[-1].start + blocks[-1].size if blocks else 0
        blocks.append(Block(name, start, size))
        return slice(start, start + size)

    def find(self, blocks: list[Block], name: str) -> slice:
        return next(b for b in blocks if b.name == name).slice

    def name_of(self, blocks: list[Block], index: int) -> str:
        return next(b.name for b in blocks if b.start <= index < b.start + b.size)


@dataclass
class Quantities:
    """The NLP's named quantities, over which the criteria write their expressions."""

    lengths: dict                   # mm
    ratio: ca.MX                    # time mean / ω1 at e = 1
    worst_ripple: ca.MX             # epigraph variable t >= δ_e for every listed e
    peak_speed: ca.MX               # ω_max at e = 1, rad/s
    cos_mu_sq: dict                 # eccentricity tag -> cos²μ of every chain at its extremes
    #: a bound's or the objective's quantity by its key (criteria.quantity_specs): the
    #: epigraph of its tracked extremes, or the envelope's own expression
    quantities: dict = field(default_factory=dict)
    #: the same specs' attained forms, where a bound on the other side or the objective's
    #: direction reads one (:meth:`PhaseNLP._quantities`)
    attained: dict = field(default_factory=dict)


class EccentricityBlock:
    """What one eccentricity block of the NLP offers the quantities' NLP forms
    (:meth:`optdesign.quantities.base.Quantity.figures`): the envelope's variables and
    expressions (speeds per unit e·ω1), cos²μ at its tracked extremes, the turn quantities'
    tracked components, and picks made at the start of each solve (a parameter one-hot over
    the candidates, :meth:`PhaseNLP.with_picks`), created when a form asks for them."""

    def __init__(self, nlp: "PhaseNLP", builder: "_Builder", tag: str, e, pvec):
        self.nlp, self.builder, self.tag, self.e, self.pvec = nlp, builder, tag, e, pvec
        self.model, self.count = nlp.model, nlp.count
        self.options = tuple(sorted(nlp.problem.options.items()))
        self.input_speed = nlp.problem.input_speed
        self.tracked: dict = {}
        # set by PhaseNLP._eccentricity
        self.w_hi = self.w_lo = self.mean = self.ripple = self.cos_sq = None
        self.peaks = self.troughs = None            # f_c at each curve's peak, f at each slot

    def ripple_of(self, high, low):
        """δ of the problem's definition from these extremes and the block's mean."""
        return ripple_of(high, low, self.mean, self.nlp.problem.objective.ripple)

    def picked_peak(self):
        """The exact peak of the curve fastest at the start (<= w_hi, the true ω_max)."""
        return self.nlp.pick(self.builder, f"peak_pick_{self.tag}", self.peaks, "max",
                             self.tag, slots=False)

    def picked_trough(self):
        """The speed at the active hand-over slowest at the start, held at its crossing
        (an envelope minimum: >= the true ω_min)."""
        return self.nlp.pick(self.builder, f"trough_pick_{self.tag}", self.troughs, "min",
                             self.tag, slots=True)


#: parameterised eccentricity slots of a problem with a regulation interval: the worst interior
#: eccentricities, held like listed ones; each slot's e is a parameter, so moving it never
#: rebuilds the NLP (docs/formulation.md, "The whole regulation range")
ECCENTRICITY_SLOTS = 2


def eccentricity_slots(problem) -> int:
    """The eccentricity slots of ``problem``'s NLP: none without a regulation interval, else
    :data:`ECCENTRICITY_SLOTS` (the worst δ and the least transmission angle) and one more
    per quantity a criterion reads over the interval (its own worst eccentricity)."""
    if problem.eccentricity_range is None:
        return 0
    return ECCENTRICITY_SLOTS + len(interval_quantities(problem))

#: parameterised scenario slots of a robust solve (``objective.robust: worst_case``): parts of
#: the tolerance box, each the design's lengths plus an offset vector that is a parameter
SCENARIO_SLOTS = 4


@dataclass(frozen=True)
class Held:
    """The eccentricity slots of one solve: each slot's e and whether it is held. An idle
    slot duplicates an end of the interval, with its variables fixed and its rows free."""

    eccentricities: tuple[float, ...] = ()
    active: tuple[bool, ...] = ()
    #: a robust solve's scenario slots: each part's length offsets (mm, the mechanism's
    #: lengths in order) and whether it is held; an idle scenario is the nominal design
    offsets: tuple[tuple[float, ...], ...] = ()
    scenario_active: tuple[bool, ...] = ()

    @classmethod
    def idle(cls, problem) -> "Held":
        """Every slot idle (at the interval's upper end; scenarios at the nominal); none
        without an interval or a robust objective."""
        out = cls()
        if problem.eccentricity_range is not None:
            upper = problem.eccentricity_range[1]
            slots = eccentricity_slots(problem)
            out = cls((upper,) * slots, (False,) * slots)
        if is_robust(problem):
            zero = (0.0,) * len(problem.model.lengths)
            out = replace(out, offsets=(zero,) * SCENARIO_SLOTS,
                          scenario_active=(False,) * SCENARIO_SLOTS)
        return out

    def held(self) -> tuple[float, ...]:
        """The eccentricities of the active slots."""
        return tuple(e for e, a in zip(self.eccentricities, self.active) if a)


#: a secondary basin's run still this infeasible (largest constraint violation, the rows' own
#: units) after STALL_AFTER iterations is stopped as stalled: a quasi-Newton run that is this
#: far off by then wanders through restoration phases to the iteration limit (disc problem,
#: n = 4: 100 iterations, then 13 more with the exact Hessian to join the best basin)
STALL_AFTER = 30
STALL_INFEASIBILITY = 1e-2
#: the least a tracked extreme of cos μ may move in one run, either way (rad). A chain's two
#: extremes lie about half a turn apart (the four-bar's cos μ is a function of cos φ about its
#: frame line: its extremes at φ = 0 and π of that line), however many curves the count makes,
#: so their window need not shrink with the curve spacing below this as the peaks' and
#: hand-overs' do (three spacings: 45° at 12 phases, where this leaves every window of 12
#: phases and fewer as it was): at 24 phases a window of 22.5° stopped the second basin's run of
#: the disc problem on its edge (its extreme moved 37°), and the re-solve from there took 23
#: iterations more (the solve's 50 in all, not 70)
MU_MIN_HALF_WINDOW = math.pi / 4
#: iterations a secondary basin's polish may take (the best-ranked basin has IPOPT's own
#: limit): one that has not converged by then creeps along a slow valley of a worse basin
#: (disc problem, n = 12: 100 L-BFGS iterations to end 1 % above the best optimum)
SECONDARY_BUDGET = 50


class _Watch(ca.Callback):
    """IPOPT's iteration callback. It stops the run

    * once its free lengths (scaled) lie within ``radius`` of one of ``known``, optima
      already found from other starts: the run has joined a known basin, and following it to
      the end would find that optimum again (``joined``);
    * with a ``budget`` (a secondary basin's polish): after :data:`STALL_AFTER` iterations
      still violating a constraint row by more than :data:`STALL_INFEASIBILITY`
      (``stalled``), and after ``budget`` iterations (``exhausted``). The best-ranked
      basin's polish runs to IPOPT's own limit.
    """

    def __init__(self, n_x: int, n_g: int, lengths: slice, radius: float = 2e-2):
        ca.Callback.__init__(self)
        self.n_x, self.n_g, self.lengths, self.radius = n_x, n_g, lengths, radius
        self.known: list[np.ndarray] = []
        self.lbg, self.ubg = np.zeros(n_g), np.zeros(n_g)
        self.joined = self.stalled = self.exhausted = False
        self.calls, self.budget = 0, None
        self.construct("watch", {})

    def start(self, known, lbg, ubg, budget: int | None = None) -> None:
        """Arm the watch for one run."""
        self.known, self.lbg, self.ubg = known, np.asarray(lbg), np.asarray(ubg)
        self.joined = self.stalled = self.exhausted = False
        self.calls, self.budget = 0, budget

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "stop"

    def get_sparsity_in(self, i):
        name = ca.nlpsol_out(i)
        if name == "f":
            return ca.Sparsity.scalar()
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self.n_x)
        if name in ("g", "lam_g"):
            return ca.Sparsity.dense(self.n_g)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        self.calls += 1
        if self.known:
            x = np.array(arg[0]).ravel()[self.lengths]
            if any(np.max(np.abs(x - k)) <= self.radius for k in self.known):
                self.joined = True
                return [1]
        if self.budget is not None and self.calls == STALL_AFTER:
            g = np.array(arg[2]).ravel()        # nlpsol_out order: x, f, g, lam_x, lam_g
            with np.errstate(invalid="ignore"):
                viol = np.nan_to_num(np.maximum(self.lbg - g, g - self.ubg), nan=np.inf)
            if viol.size and viol.max() > STALL_INFEASIBILITY:
                self.stalled = True
                return [1]
        if self.budget is not None and self.calls > self.budget:
            self.exhausted = True
            return [1]
        return [0]


class _Builder:
    """Collects the NLP's variables, parameters and constraint rows, each a named block."""

    def __init__(self, layout: Layout):
        self.layout, self.x, self.p, self.g = layout, [], [], []

    def variable(self, name: str, size: int):
        v = ca.MX.sym(name, size)
        self.layout.add(self.layout.x, name, size)
        self.x.append(v)
        return v

    def parameter(self, name: str, rows: int, cols: int = 1):
        v = ca.MX.sym(name, rows, cols)
        self.layout.add(self.layout.p, name, rows * cols)
        self.p.append(ca.vec(v))
        return v

    def row(self, name: str, expr) -> None:
        self.layout.add(self.layout.g, name, expr.numel())
        self.g.append(expr)


def _library_named(record: dict, hessian: str):
    """The intact compiled library an NLP's record names for ``hessian``, or None."""
    libraries = record.get("libraries")
    digest = libraries.get(hessian) if isinstance(libraries, dict) else None
    return compiled.library_of(digest) if isinstance(digest, str) else None


def smooth_max(values, rho):
    """log-sum-exp maximum, (1/ρ)·log Σ exp(ρ·v) >= max v, shifted by max v for stability.

    The shift cancels in value and in every derivative (the softmax weights sum to one), so
    the non-smooth ``mmax`` only guards the exponent's range.
    """
    top = ca.mmax(values)
    return top + ca.log(ca.sum1(ca.exp(rho * (values - top)))) / rho


def _wrap(angle):
    """Angle difference wrapped to (-π, π]: rockers swing less than half a turn per run."""
    return ca.atan2(ca.sin(angle), ca.cos(angle))


def tag_of(e: float) -> str:
    return f"e{e:g}"


def is_robust(problem) -> bool:
    """A robust solve: the worst δ over the tolerance box, every part feasible."""
    return getattr(problem.objective, "robust", "none") == "worst_case"


def scenario_tag(j: int) -> str:
    """The name of scenario slot j (its criterion rows end in ``[s{j}]``)."""
    return f"s{j}"


def slot_tag(j: int) -> str:
    """The name of eccentricity slot j in the NLP's blocks (its e is a parameter)."""
    return f"slot{j}"


class PhaseNLP:
    """The NLP of one phase count; ``slots`` hand-over slots per eccentricity.

    Parameters ``p``: the fixed lengths, then per eccentricity the slots' curve selections
    (``before``, ``after``: (curves + 1) × slots, the last curve the output at rest), their
    ``active`` and ``last`` flags.
    """

    def __init__(self, problem, count: int, slots: int | None = None):
        self.problem = problem
        self.count = count
        model = problem.model
        self.model = model
        self.free = problem.free_lengths()
        self.fixed = [k for k in model.lengths if k not in self.free]
        # geometric mean of the bounds: O(1) scaled variables even when a range spans decades
        self.scale = np.array([math.sqrt(problem.design[k].lower * problem.design[k].upper)
                               for k in self.free])
        self.signs = STROKE_SIGNS[problem.stroke]
        self.n_curves = count * len(self.signs)
        self.slots = slots or self.n_curves
        self.eccs = eccentricities_of(problem)
        self.listed = [i for i, e in enumerate(self.eccs) if e in problem.eccentricities]
        self.n_slots = eccentricity_slots(problem)
        #: the eccentricity blocks in order: e = 1 and the listed ones, then the slots
        self.slot_tags = [slot_tag(j) for j in range(self.n_slots)]
        self.tags = [tag_of(e) for e in self.eccs] + self.slot_tags
        self.n_scenarios = SCENARIO_SLOTS if is_robust(problem) else 0
        #: per scenario, its eccentricity blocks (after the nominal's and the slots')
        self.scenario_tags = [[f"{tag_of(e)}_{scenario_tag(j)}" for e in self.eccs]
                              for j in range(self.n_scenarios)]
        self.tags += [t for tags in self.scenario_tags for t in tags]
        self.phi = np.linspace(0.0, 2 * math.pi, problem.solver.samples, endpoint=False)
        self.has_mu = model.has_transmission_angle(count, tuple(sorted(problem.options.items())))
        self.criteria = constraints_of(problem)
        self.objective = objective_of(problem)
        #: bounds and the objective on quantities; the turn quantities among them are
        #: tracked at exact stationary points in every listed eccentricity's block
        self.specs = quantity_specs(problem)
        #: the quantities whose figures need variables and rows of their own in a block
        #: (a turn quantity's stationary points), filled as the blocks are built
        self.turn: list[str] = []
        #: per spec, the forms its bounds and the objective read: ``natural`` (conservative
        #: towards the quantity's natural side) and ``attained`` (for the other side)
        sides = spec_sides(problem, self.specs)
        self.forms = spec_forms(problem, self.specs, sides)
        #: what they need held exactly beyond the conservative forms (a cap on the ratio: the
        #: hand-over angles at the curves' crossings)
        self.needs = frozenset().union(*(get_quantity(s.name).nlp_needs(sides[s.key])
                                         for s in self.specs))
        #: the picks of the attained forms, (name, candidates, worst, block tag, among the
        #: active hand-over slots only), and each one's one-hot parameter by name
        self._picks: list[tuple] = []
        self._pick_params: dict = {}
        #: (quantity, block tag) of every block that tracks a quantity's figures
        self._tracked: set = set()
        self.layout = Layout()
        self._solvers: dict = {}        # hessian, or (hessian, "warm") -> IPOPT
        self.watch: _Watch | None = None
        #: the C heap's bytes this NLP holds: its graph and each IPOPT built on it (what
        #: their builds left allocated, :mod:`optdesign.numerics.heap`; 0 where unknown)
        self.held_bytes = 0
        #: the name of this NLP's record beside its compiled library (:mod:`.nlp_memo`: None
        #: where nothing is cached), and the record, where one was read and used: then the
        #: graph is built only when something asks for it (:meth:`__getattr__`)
        self._record_key = nlp_memo.key_of(problem, count, self.slots, self.criteria,
                                           IPOPT_OPTIONS)
        self._record: dict | None = None
        #: per Hessian, the library checked intact as the record was read
        self._libraries: dict = {}
        before = heap.in_use()
        if not self._restored(nlp_memo.read(self._record_key)):
            self._build()
        self.held_bytes += heap.grown_since(before)

    #: what only the graph holds: asked of an NLP made from its record, the graph is built
    GRAPH = ("x_sym", "p_sym", "f", "g")

    def __getattr__(self, name):
        if name in self.GRAPH and self.__dict__.get("_record") is not None:
            self._rebuilt()
            return self.__dict__[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    # ------------------------------------------------------------------ its record
    def _restored(self, record: dict | None) -> bool:
        """This NLP made from its ``record`` (:mod:`.nlp_memo`) instead of its graph: its
        layout, what the build learns and its three small functions, where the record names
        a library of the problem's Hessian that is intact; False (nothing set) otherwise."""
        if record is None:
            return False
        hessian = self.problem.solver.hessian
        path = _library_named(record, hessian)
        if path is None:
            return False
        try:
            layout = Layout(*([Block(str(n), int(a), int(z)) for n, a, z in record["layout"][k]]
                              for k in ("x", "g", "p")))
            fill, surrogate, candidates = (ca.Function.deserialize(record["functions"][k])
                                           for k in ("fill", "surrogate", "candidates"))
            picks = [(str(n), None, str(w), str(t), bool(z)) for n, w, t, z in record["picks"]]
            blocks = [(str(n), self.criteria[int(i)]) for n, i in record["criterion_blocks"]]
            derived = dict.fromkeys(str(n) for n in record["derived"])
            tracked = {(str(n), str(t)) for n, t in record["tracked"]}
            turn = [str(n) for n in record["turn"]]
            n_x, n_g, n_p = (int(record[k]) for k in ("n_x", "n_g", "n_p"))
        except (KeyError, TypeError, ValueError, IndexError, RuntimeError):
            return False
        if fill.n_out() != len(derived) or candidates.n_out() != len(picks) or \
                fill.nnz_in(0) != n_x or fill.nnz_in(1) != n_p:
            return False
        self.layout, self._fill, self.surrogate, self._candidates = layout, fill, surrogate, \
            candidates
        self._picks, self._criterion_blocks, self._derived = picks, blocks, derived
        self._tracked, self.turn = tracked, turn
        self.n_x, self.n_g, self.n_p = n_x, n_g, n_p
        self._record = record
        self._libraries[hessian] = path
        return True

    def _rebuilt(self) -> None:
        """The graph of an NLP made from its record, built now (the same layout and
        functions as the record's: the build is the one that wrote it)."""
        self._record = None
        self.layout, self._picks, self._pick_params = Layout(), [], {}
        self._tracked, self.turn = set(), []
        before = heap.in_use()
        self._build()
        self.held_bytes += heap.grown_since(before)

    def _kept_as_record(self, hessian: str, digest: str) -> None:
        """Keep this NLP's record (:mod:`.nlp_memo`), its library for ``hessian`` being the
        one of ``digest`` (found cached: a record is written only beside a library)."""
        if self._record_key is None:
            return
        known = (nlp_memo.read(self._record_key) or {}).get("libraries")
        libraries = (known if isinstance(known, dict) else {}) | {hessian: digest}
        index = {id(c): i for i, c in enumerate(self.criteria)}
        L = self.layout
        nlp_memo.write(self._record_key, {
            "libraries": libraries,
            "layout": {k: [[b.name, b.start, b.size] for b in getattr(L, k)]
                       for k in ("x", "g", "p")},
            "functions": {"fill": self._fill.serialize(),
                          "surrogate": self.surrogate.serialize(),
                          "candidates": self._candidates.serialize()},
            "picks": [[n, w, t, bool(z)] for n, _, w, t, z in self._picks],
            "criterion_blocks": [[n, index[id(c)]] for n, c in self._criterion_blocks],
            "derived": list(self._derived), "tracked": sorted(self._tracked),
            "turn": list(self.turn), "n_x": self.n_x, "n_g": self.n_g, "n_p": self.n_p})

    # ------------------------------------------------------------------ building
    def _sample_function(self, fn) -> ca.Function:
        """(φ, p, 1/e) -> (cos²μ of every chain, smooth max of the curves): one sample."""
        phi = ca.SX.sym("phi")
        pv = ca.SX.sym("p", len(self.model.lengths))
        inv_e = ca.SX.sym("inv_e")
        _, dth, _, cos_mu = fn(phi, pv)
        f = ca.vertcat(*[s * dth * inv_e for s in self.signs])
        return ca.Function("sample", [phi, pv, inv_e],
                           [cos_mu ** 2, smooth_max(f, self.problem.solver.smoothing), f])

    @staticmethod
    def _slot_function(fn) -> ca.Function:
        """(φ, p) -> (θ, dθ/dφ) of every chain: what a hand-over slot reads, and no more."""
        phi, pv = ca.SX.sym("phi"), ca.SX.sym("p", fn.size1_in(1))
        theta, dtheta, _, _ = fn.call([phi, pv], True, False)
        return ca.Function("slot", [phi, pv], [theta, dtheta])

    def _points_function(self) -> ca.Function:
        """(φ_peak (curves), φ_μ (2 per chain), p, 1/e) -> (f_c and f_c' at each curve's peak
        angle, cos μ and d cos μ/dφ at each chain's two extreme angles): one SX function in
        which each point evaluates its own chain alone."""
        options = tuple(sorted(self.problem.options.items()))
        chains = [self.model.chain(self.count, options, k) for k in range(self.count)]
        phi_m = ca.SX.sym("phi_m", self.n_curves)
        phi_mu = ca.SX.sym("phi_mu", 2 * self.count if self.has_mu else 0)
        pv = ca.SX.sym("p", len(self.model.lengths))
        inv_e = ca.SX.sym("inv_e")
        f, df, cos_x, dcos_x = [], [], [], []
        for c in range(self.n_curves):
            s, k = self.signs[c // self.count], c % self.count
            _, dth, ddth, _, _ = chains[k].call([phi_m[c], pv], True, False)
            f.append(s * dth * inv_e)
            df.append(s * ddth * inv_e)
        for j in range(phi_mu.numel()):
            _, _, _, cos_mu, dcos_mu = chains[j % self.count].call([phi_mu[j], pv], True, False)
            cos_x.append(cos_mu)
            dcos_x.append(dcos_mu)
        return ca.Function("points", [phi_m, phi_mu, pv, inv_e],
                           [ca.vertcat(*f), ca.vertcat(*df), ca.vertcat(ca.SX(0, 1), *cos_x),
                            ca.vertcat(ca.SX(0, 1), *dcos_x)])

    def _stack(self, rows):
        """Curves × points from chains × points (stroke signs applied), plus the rest curve."""
        return ca.vertcat(*[s * rows for s in self.signs], ca.MX(1, rows.shape[1]))

    def _build(self):
        P, L = self.problem, self.layout
        b = _Builder(L)
        xs = b.variable("lengths", len(self.free))
        fixed = b.parameter("fixed", len(self.fixed))
        lengths = {k: xs[i] * self.scale[i] for i, k in enumerate(self.free)}
        lengths |= {k: fixed[i] for i, k in enumerate(self.fixed)}
        fn = self.model.kinematics(self.count, tuple(sorted(P.options.items())))
        functions = (self._sample_function(fn).map(self.phi.size), self._points_function(),
                     self._slot_function(fn).map(self.slots))
        self._derived: dict[str, ca.MX] = {}
        slots = [b.parameter(f"eccentricity_{slot_tag(j)}", 1) for j in range(self.n_slots)]
        every: list[EccentricityBlock] = []

        def blocks(part: dict, tags, eccs) -> dict:
            """One eccentricity block per (tag, e) for the lengths ``part``."""
            out = {}
            for tag, e in zip(tags, eccs):
                pvec = ca.vertcat(*[part[k] * (e if k == self.model.regulating_variable else 1)
                                    for k in self.model.lengths])
                out[tag] = self._eccentricity(b, tag, e, pvec, functions)
                every.append(out[tag])
            return out

        nominal = blocks(lengths, self.tags, list(self.eccs) + slots)
        ripples = [x.ripple for x in nominal.values()]
        t = b.variable("worst_ripple", 1)
        b.row("ripple_epigraph", ca.vertcat(*[t - ripples[i] for i in self.listed]))
        if self.n_slots:            # the held interior eccentricities (free rows when idle)
            b.row("ripple_epigraph_slots", ca.vertcat(*[t - r for r in ripples[len(self.eccs):]]))
        first = nominal[self.tags[0]]
        q = Quantities(lengths, first.mean, t, first.w_hi * P.input_speed,
                       {tag: x.cos_sq for tag, x in nominal.items()},
                       *self._quantities(b, nominal, self.tags))
        self._criterion_blocks = []
        for criterion in self.criteria:
            for name, expr in criterion.rows(q):
                b.row(name, ca.vertcat(expr))
                self._criterion_blocks.append((name, criterion))
        # Scenarios: the same blocks for a part of the tolerance box (lengths + offsets, a
        # parameter), under the same epigraph t, with every constraint row again.
        for j in range(self.n_scenarios):
            offsets = b.parameter(f"offsets_{scenario_tag(j)}", len(self.model.lengths))
            part = {k: lengths[k] + offsets[i] for i, k in enumerate(self.model.lengths)}
            own = blocks(part, self.scenario_tags[j], self.eccs)
            tags = self.scenario_tags[j]
            b.row(f"ripple_epigraph[{scenario_tag(j)}]",
                  ca.vertcat(*[t - own[tags[i]].ripple for i in self.listed]))
            head = own[tags[0]]
            qj = Quantities(part, head.mean, t, head.w_hi * P.input_speed,
                            {tag: x.cos_sq for tag, x in own.items()},
                            *self._quantities(b, own, tags, scenario_tag(j)))
            for criterion in self.criteria:
                for name, expr in criterion.rows(qj):
                    if not name.endswith(f"_{scenario_tag(j)}]"):
                        name = f"{name}[{scenario_tag(j)}]"
                    b.row(name, ca.vertcat(expr))
                    self._criterion_blocks.append((name, criterion))
        self.x_sym, self.p_sym = ca.vertcat(*b.x), ca.vertcat(*b.p)
        #: the auxiliary variables' values as functions of the others, to start them on
        self._fill = ca.Function("fill", [self.x_sym, self.p_sym], list(self._derived.values()))
        self.g = ca.vertcat(*b.g)
        self.f = self.objective.expression(q)
        self.n_x, self.n_g, self.n_p = self.x_sym.numel(), self.g.numel(), self.p_sym.numel()
        self.surrogate = ca.Function("surrogate", [self.x_sym, self.p_sym],
                                     [ca.vertcat(*[x.ripple for x in every]),
                                      ca.vertcat(*[x.mean for x in every]),
                                      ca.vertcat(*[x.w_hi for x in every])])
        #: the candidates of every pick, evaluated at a run's start (:meth:`with_picks`)
        self._candidates = ca.Function("candidates", [self.x_sym, self.p_sym],
                                       [c for _, c, _, _, _ in self._picks])

    def _quantities(self, b: "_Builder", blocks: dict, tags, scenario: str = ""):
        """Each quantity spec's value for one part (the nominal, or ``scenario``'s part), in
        the forms its bounds and the objective read (:attr:`forms`): ``natural``, the figures'
        epigraph z over the spec's eccentricity blocks (rows z - c >= 0 for every figure c of
        a quantity whose larger figures are worse, c - z >= 0 for the others: a bound on z, or
        z as the objective, holds every figure), or the figure itself where the spec has one;
        ``attained``, the figure the start has worst, picked (:meth:`pick`), from the
        figures the design attains. ``blocks``: the part's blocks by tag, ``tags`` in
        :attr:`eccs` order. The nominal's spec at its worst covers the regulation interval's
        slots too, a row block per slot (free while the slot is idle); a scenario's variables
        and rows carry its name (fixed and free while it is idle). Returns (natural,
        attained), each by the spec's key."""
        natural, attained = {}, {}
        listed = [tags[i] for i in self.listed]
        mark, where = (f"_{scenario}", f"[{scenario}]") if scenario else ("", "")
        for spec in self.specs:
            quantity = get_quantity(spec.name)
            e = spec.at if spec.at is not None else quantity.at
            at = [tags[self.eccs.index(e)]] if e is not None else listed
            slots = self.slot_tags if e is None and not scenario else []
            sign = 1 if quantity.figure_worst == "max" else -1
            forms = self.forms[spec.key]
            if "natural" in forms:
                figures = ca.vertcat(*[f for tag in at for f in quantity.figures(blocks[tag])])
                if figures.numel() == 1 and not slots:
                    natural[spec.key] = figures
                else:
                    z = b.variable(f"quantity_{spec.key}{mark}", 1)
                    b.row(f"quantity_epigraph_{spec.key}{where}", sign * (z - figures))
                    for tag in slots:
                        b.row(f"quantity_epigraph_{spec.key}[{tag}]",
                              sign * (z - ca.vertcat(*quantity.figures(blocks[tag]))))
                    natural[spec.key] = z
            if "attained" in forms:
                figures = ca.vertcat(*[f for tag in at + slots
                                       for f in quantity.figures(blocks[tag], attained=True)])
                attained[spec.key] = figures if figures.numel() == 1 else self.pick(
                    b, f"pick_{spec.key}{mark}", figures, quantity.figure_worst)
        return natural, attained

    def pick(self, b: "_Builder", name: str, candidates, worst: str, tag: str = "",
             slots: bool = False):
        """Σ pick_i · candidates_i with ``pick`` a one-hot parameter ``name``, set at each
        run's start on the candidate that is worst there (:meth:`with_picks`; ``slots``: among
        the active hand-over slots of block ``tag`` only); made once per name."""
        if name not in self._pick_params:
            self._pick_params[name] = b.parameter(name, candidates.numel())
            self._picks.append((name, candidates, worst, tag, slots))
        return ca.dot(self._pick_params[name], candidates)

    def _track(self, b: "_Builder", block: EccentricityBlock) -> None:
        """The block's variables and rows of every quantity a spec names (a turn quantity's
        stationary points, :meth:`~optdesign.quantities.base.Quantity.track`): in the listed
        eccentricities' blocks, the regulation interval's slots and the scenarios' listed
        blocks."""
        held = [self.tags[i] for i in self.listed] + self.slot_tags + \
            [tags[i] for tags in self.scenario_tags for i in self.listed]
        if block.tag not in held:
            return
        for name in dict.fromkeys(s.name for s in self.specs):
            get_quantity(name).track(b, block)
            if name in block.tracked:
                self._tracked.add((name, block.tag))
                if name not in self.turn:
                    self.turn.append(name)

    def _eccentricity(self, b: "_Builder", tag: str, e, pvec, functions):
        """The variables and rows of one eccentricity block ``tag``, as an
        :class:`EccentricityBlock` (δ_e, mean_e, w_hi, cos²μ rows, the peaks and troughs).
        ``e`` is a number, or a parameter (an eccentricity slot).

        Speeds are in units of e·ω1: they shrink like e, and at e = 1e-6 they would sit below
        IPOPT's tolerances (ripple and ratio are ratios, so the unit cancels).
        """
        sample_map, points, slot_map = functions
        C, M = self.n_curves, self.slots
        block = EccentricityBlock(self, b, tag, e, pvec)
        w = b.variable(f"w_{tag}", 2)
        w_hi, w_lo = w[0], w[1]
        cos_mu_sq, lse, f_samples = sample_map(self.phi[None, :], pvec, 1.0 / e)
        # cos μ: where it moves with the crank, its two extremes per chain are tracked at
        # exact stationary points (below) and hold the bound between samples; rows at every
        # sample would repeat them at many times the cost (a switch of the extreme to another
        # local peak is caught by the exact check, which re-solves). Where it does not move,
        # one sample is its value.
        cos_sq = ca.MX(0, 1) if self.has_mu else ca.vec(cos_mu_sq[:, 0])
        b.row(f"trough_samples[{tag}]", ca.vec(lse) - w_lo)
        if self.problem.solver.peak_samples:      # a safety net: ω_max bounded at every sample
            b.row(f"peak_samples[{tag}]", ca.vec(w_hi - f_samples))
        # Exact peaks: one stationary point per curve; with a transmission angle, the largest
        # and the least cos μ of every chain at a stationary point of its own, so the bound
        # holds between samples too.
        phi_m = b.variable(f"phi_peak_{tag}", C)
        phi_mu = b.variable(f"phi_mu_{tag}", 2 * self.count) if self.has_mu else ca.MX(0, 1)
        f_m, df_m, cos_x, dcos_x = points(phi_m, phi_mu, pvec, 1.0 / e)
        b.row(f"peak_stationary[{tag}]", df_m)
        b.row(f"peak_points[{tag}]", w_hi - f_m)
        if self.has_mu:
            b.row(f"mu_stationary[{tag}]", dcos_x)
            cos_sq = ca.vertcat(cos_sq, cos_x ** 2)
        self._track(b, block)
        # Exact troughs at the hand-overs, and the exact mean over the runs.
        phi_x = b.variable(f"phi_handover_{tag}", M)
        before = b.parameter(f"before_{tag}", C + 1, M)
        after = b.parameter(f"after_{tag}", C + 1, M)
        active = b.parameter(f"active_{tag}", M)
        last = b.parameter(f"last_{tag}", M)
        th_x, dth_x = slot_map(phi_x.T, pvec)
        f_x, th = self._stack(dth_x / e), self._stack(th_x)
        f_before, f_after = ca.sum1(before * f_x).T, ca.sum1(after * f_x).T
        b.row(f"trough_handovers[{tag}]", ca.vertcat(f_before - w_lo, f_after - w_lo))
        if "exact_handovers" in self.needs:
            # each active hand-over at the crossing of its two curves: the runs' angle
            # increments are then the exact mean, not a lower estimate
            b.row(f"handover_crossings[{tag}]", f_before - f_after)
        th_start = ca.sum1(after * th).T
        th_next = ca.sum1(after * ca.horzcat(th[:, 1:], th[:, :1])).T
        th_first = ca.sum1(after * ca.repmat(th[:, 0], 1, M)).T
        th_end = (1 - last) * th_next + last * th_first
        # The mean as a running sum over the runs, one variable per slot (s_i = s_{i-1} +
        # increment_i): the same value as one sum, but no row then reads every hand-over
        # angle, so the Jacobian needs a few forward directions instead of one per slot.
        increments = active * _wrap(th_end - th_start)
        sums = b.variable(f"run_sums_{tag}", M)
        b.row(f"run_sums[{tag}]", sums - ca.vertcat(0, sums[:-1]) - increments)
        self._derived[f"run_sums_{tag}"] = ca.cumsum(increments)
        block.w_hi, block.w_lo, block.cos_sq = w_hi, w_lo, cos_sq
        block.mean = sums[M - 1] / (2 * math.pi * e)
        block.ripple = block.ripple_of(w_hi, w_lo)
        block.peaks, block.troughs = f_m, f_before
        return block

    def solver(self, hessian: str, warm: bool = False) -> ca.Function:
        """IPOPT on this NLP with the exact Hessian or L-BFGS; each built at its first use, on
        the NLP's compiled derivatives where they are cached (:mod:`optdesign.solver.compiled`).
        ``warm``: the IPOPT of a run from a neighbour's primal-dual optimum
        (:data:`WARM_OPTIONS`), on the same library.

        Every iteration passes through :attr:`watch`, which stops a run that has entered the
        neighbourhood of an optimum found already (its basin is known)."""
        key = (hessian, "warm") if warm else hessian
        if key not in self._solvers:
            if self.watch is None:
                self.watch = _Watch(self.n_x, self.n_g, self.layout.find(self.layout.x,
                                                                          "lengths"))
            opts = dict(IPOPT_OPTIONS) | {"ipopt.max_iter": iterations_of(self.problem),
                                          "ipopt.hessian_approximation": hessian,
                                          "iteration_callback": self.watch} | \
                (WARM_OPTIONS if warm else {})
            before = heap.in_use()
            name = f"nlp_n{self.count}"
            path = None
            if self._record is not None:
                path = self._libraries.get(hessian) or _library_named(self._record, hessian)
            if path is not None:            # made from its record: the library it names
                self._solvers[key] = compiled.nlpsol_of(name, path, opts)
            else:
                found: dict = {}
                self._solvers[key] = compiled.nlpsol(name, self.x_sym, self.p_sym, self.f,
                                                     self.g, opts, found)
                if "digest" in found:
                    self._kept_as_record(hessian, found["digest"])
            self.held_bytes += heap.grown_since(before)
        return self._solvers[key]

    # ------------------------------------------------------------------ per solve
    def _held(self, held: Held | None) -> Held:
        return held if held is not None else Held.idle(self.problem)

    def idle_tags(self, held: Held | None) -> set[str]:
        """The tags of the eccentricity and scenario slots not held in this solve (a
        scenario's: its own and those of its eccentricity blocks)."""
        held = self._held(held)
        out = {slot_tag(j) for j in range(self.n_slots) if not held.active[j]}
        for j in range(self.n_scenarios):
            if not held.scenario_active[j]:
                out |= {scenario_tag(j), *self.scenario_tags[j]}
        return out

    def parameters(self, sequences, held: Held | None = None) -> np.ndarray:
        """The fixed lengths, the eccentricity slots' e (``held``; every slot idle by
        default) and the hand-over slots' selections for one hand-over sequence per
        eccentricity block (:attr:`tags`: e = 1, the listed ones, then the slots)."""
        P, L = self.problem, self.layout
        p = np.zeros(self.n_p)
        p[L.find(L.p, "fixed")] = [P.design[k].value for k in self.fixed]
        for j, e in enumerate(self._held(held).eccentricities[:self.n_slots]):
            p[L.find(L.p, f"eccentricity_{slot_tag(j)}")] = e
        for j, offsets in enumerate(self._held(held).offsets[:self.n_scenarios]):
            p[L.find(L.p, f"offsets_{scenario_tag(j)}")] = offsets
        C, M = self.n_curves, self.slots
        for tag, seq in zip(self.tags, sequences):
            m = len(seq)
            before, after = np.zeros((C + 1, M)), np.zeros((C + 1, M))
            before[C, :] = after[C, :] = 1.0                     # idle slots: the rest curve
            active, last = np.zeros(M), np.zeros(M)
            for i in range(m):
                before[:, i] = after[:, i] = 0.0
                before[min(seq[i - 1], C), i] = 1.0
                after[min(seq[i], C), i] = 1.0
                active[i] = 1.0
            last[m - 1] = 1.0
            for name, value in (("before", before), ("after", after), ("active", active),
                                ("last", last)):
                p[L.find(L.p, f"{name}_{tag}")] = value.ravel(order="F")
        return p

    def with_picks(self, x0: np.ndarray, p: np.ndarray, sequences) -> np.ndarray:
        """``p`` with every pick (:meth:`pick`) on its worst candidate at the start ``x0``: a
        block's picks (its fastest curve, its slowest active hand-over) first, then the specs'
        over figures that read them."""
        if not self._picks:
            return p
        p = np.array(p, dtype=float)
        active = {tag: len(seq) for tag, seq in zip(self.tags, sequences)}
        for _ in range(2):
            values = self._candidates.call([x0, p])
            for (name, _, worst, tag, slots), v in zip(self._picks, values):
                v = np.array(v, dtype=float).ravel()
                if slots:
                    v = np.where(np.arange(v.size) < active.get(tag, v.size), v,
                                 -np.inf if worst == "max" else np.inf)
                v = np.nan_to_num(v, nan=-np.inf if worst == "max" else np.inf)
                one = np.zeros(v.size)
                one[int(np.argmax(v) if worst == "max" else np.argmin(v))] = 1.0
                p[self.layout.find(self.layout.p, name)] = one
        return p

    def picks_moved(self, x: np.ndarray, p: np.ndarray, sequences) -> bool:
        """Whether a pick's worst candidate at the solution ``x`` is another than the one the
        run held (the attained figure moved to another curve, hand-over or joint): the
        driver re-solves with the picks made there."""
        return bool(self._picks) and not np.array_equal(self.with_picks(x, p, sequences), p)

    def constraint_bounds(self, problem, sequences, tightening_deg: float = 0.0,
                          held: Held | None = None, guess: dict | None = None):
        """lbg, ubg of one solve: the criteria's bounds (for ``problem``'s ε and caps), the
        envelope rows, idle hand-over slots switched off, and every row of an idle
        eccentricity slot free; a tracked component that ``guess`` finds constant over the
        turn has no stationary point to hold (its row free)."""
        L = self.layout
        lbg, ubg = np.zeros(self.n_g), np.full(self.n_g, np.inf)
        for tag, seq in zip(self.tags, sequences):
            for block in ("peak_stationary", "mu_stationary", "run_sums"):
                if self.has_mu or block != "mu_stationary":
                    lbg[L.find(L.g, f"{block}[{tag}]")] = ubg[L.find(L.g, f"{block}[{tag}]")] = 0.0
            for name in self.turn:
                if (name, tag) in self._tracked:
                    rows = L.find(L.g, f"q_stationary_{name}[{tag}]")
                    constant = np.asarray((guess or {}).get(f"constant_{name}_{tag}", False))
                    lbg[rows] = np.where(constant, -np.inf, 0.0)
                    ubg[rows] = np.where(constant, np.inf, 0.0)
            rows = L.find(L.g, f"trough_handovers[{tag}]")
            idle = np.ones(self.slots, bool)
            idle[:len(seq)] = False
            lbg[rows] = np.where(np.concatenate([idle, idle]), -np.inf, 0.0)
            if "exact_handovers" in self.needs:
                rows = L.find(L.g, f"handover_crossings[{tag}]")
                lbg[rows] = np.where(idle, -np.inf, 0.0)
                ubg[rows] = np.where(idle, np.inf, 0.0)
        for name, criterion in self._criterion_blocks:
            lower, upper = criterion.row_bounds(problem, name, tightening_deg)
            lbg[L.find(L.g, name)], ubg[L.find(L.g, name)] = lower, upper
        if self.n_slots or self.n_scenarios:
            idle = self.idle_tags(held)
            if self.n_slots:
                rows = L.find(L.g, "ripple_epigraph_slots")
                lbg[rows] = [-np.inf if slot_tag(j) in idle else 0.0
                             for j in range(self.n_slots)]
            for block in L.g:
                if any(block.name.endswith(f"[{tag}]") for tag in idle):
                    lbg[block.slice], ubg[block.slice] = -np.inf, np.inf
        return lbg, ubg

    def bounds(self, guess: dict, sequences,
               held: Held | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Variable bounds: the design's bounds, windows around the start's angles, idle
        slots fixed (hand-over slots, and every variable of an idle eccentricity slot)."""
        P, L = self.problem, self.layout
        lbx, ubx = np.full(self.n_x, -np.inf), np.full(self.n_x, np.inf)
        sl = L.find(L.x, "lengths")
        lbx[sl] = [P.design[k].lower / s for k, s in zip(self.free, self.scale)]
        ubx[sl] = [P.design[k].upper / s for k, s in zip(self.free, self.scale)]
        # Each tracked peak and hand-over may move 3 curve spacings' worth (at most 60°): far
        # enough that a polish from a distant seed rarely runs into a window edge (each edge
        # costs a re-solve), near enough that a peak's point cannot reach the same curve's
        # minimum (about half a turn away), nor a hand-over the pair's other crossing; an
        # extreme of cos μ at least 45° (MU_MIN_HALF_WINDOW).
        half_window = min(3 * math.pi / self.n_curves, math.pi / 3)
        for tag, seq in zip(self.tags, sequences):
            sl = L.find(L.x, f"phi_peak_{tag}")
            lbx[sl], ubx[sl] = guess[f"phi_peak_{tag}"] - half_window, \
                guess[f"phi_peak_{tag}"] + half_window
            if self.has_mu:
                sl = L.find(L.x, f"phi_mu_{tag}")
                mu_window = max(half_window, MU_MIN_HALF_WINDOW)
                lbx[sl], ubx[sl] = guess[f"phi_mu_{tag}"] - mu_window, \
                    guess[f"phi_mu_{tag}"] + mu_window
            sl = L.find(L.x, f"phi_handover_{tag}")
            centre = guess[f"phi_handover_{tag}"]
            active = np.arange(self.slots) < len(seq)
            lbx[sl] = np.where(active, centre - half_window, centre)
            ubx[sl] = np.where(active, centre + half_window, centre)
            for name in self.turn:
                if (name, tag) in self._tracked:
                    sl = L.find(L.x, f"phi_q_{name}_{tag}")
                    centre = np.asarray(guess[f"phi_q_{name}_{tag}"], dtype=float)
                    constant = np.asarray(guess.get(f"constant_{name}_{tag}", False))
                    lbx[sl] = np.where(constant, centre, centre - half_window)
                    ubx[sl] = np.where(constant, centre, centre + half_window)
            lbx[L.find(L.x, f"w_{tag}")] = 0.0
            # each increment is a wrapped angle, |Δθ| <= π, so the i-th running sum lies in
            # ±(i + 1)π: bounds that are never active at a solution but keep a linear
            # objective in the sum (largest ratio) from long excursions (pulse reducer: 18
            # IPOPT iterations with them, 200 without)
            reach = math.pi * np.arange(1, self.slots + 1)
            sl = L.find(L.x, f"run_sums_{tag}")
            lbx[sl], ubx[sl] = -reach, reach
        for tag in self.idle_tags(held):
            for block in L.x:
                if block.name.endswith(f"_{tag}"):
                    value = np.zeros(block.size) if block.name in self._derived else \
                        np.atleast_1d(np.asarray(guess[block.name], dtype=float))[:block.size]
                    lbx[block.slice] = ubx[block.slice] = value
        return lbx, ubx

    def at_window_bound(self, x, lbx, ubx, tol: float = 1e-6) -> bool:
        """True when a tracked angle (peak or hand-over) ended on the edge of its window: the
        point moved further than the window allows, so the driver re-centres and re-solves."""
        for block in self.layout.x:
            if block.name.startswith(("phi_peak", "phi_handover", "phi_mu", "phi_q_")):
                sl = block.slice
                free = ubx[sl] > lbx[sl]
                if np.any(free & ((x[sl] - lbx[sl] < tol) | (ubx[sl] - x[sl] < tol))):
                    return True
        return False

    def output_at_rest(self, x, lam_x, tol: float = 1e-9) -> bool:
        """True when an eccentricity block's trough ``w_lo`` ended on its bound 0 and holds
        the solution there (a multiplier): the output comes to rest once a turn. The NLP's
        hand-overs cannot cross below zero where the exact envelope, clipped at rest, goes on
        (δ = 2 for the midrange ripple), so the optimum there may be the NLP's edge and not
        the problem's."""
        lam_x = np.asarray(lam_x, dtype=float).ravel()
        for block in self.layout.x:
            if block.name.startswith("w_"):
                lo = block.slice.start + 1
                if x[lo] <= tol and abs(lam_x[lo]) > tol:
                    return True
        return False

    def lengths_of(self, x: np.ndarray) -> dict[str, float]:
        """The free lengths in mm, clipped to their bounds (IPOPT may relax a bound by ~1e-8)."""
        sl = self.layout.find(self.layout.x, "lengths")
        P = self.problem
        return {k: float(np.clip(v * s, P.design[k].lower, P.design[k].upper))
                for k, v, s in zip(self.free, x[sl], self.scale)}

    def pack(self, guess: dict) -> np.ndarray:
        """x from the guessed blocks; the auxiliary ones (running sums) are left at zero for
        :meth:`complete`."""
        x0 = np.zeros(self.n_x)
        for block in self.layout.x:
            if block.name in self._derived:
                continue
            value = np.atleast_1d(np.asarray(guess[block.name], dtype=float))
            x0[block.start:block.start + value.size] = value[:block.size]
        return x0

    def start(self, guess: dict, lbx, ubx, p) -> np.ndarray:
        """The initial x of a run: the guess within its bounds, the auxiliary variables
        consistent with the rest."""
        return np.clip(self.complete(np.clip(self.pack(guess), lbx, ubx), p), lbx, ubx)

    def complete(self, x0: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``x0`` with its auxiliary variables set consistently with the others."""
        x0 = np.array(x0, dtype=float)
        for name, value in zip(self._derived, self._fill.call([x0, p])):
            x0[self.layout.find(self.layout.x, name)] = np.array(value).ravel()
        return x0

    def worst_ripple(self, x, p, held: Held | None = None) -> float:
        """The surrogate's worst δ over the listed eccentricities and the held slots at
        ``x``."""
        ripples = np.array(self.surrogate(x, p)[0]).ravel()
        idle = self.idle_tags(held) if self.n_slots or self.n_scenarios else set()
        rows = self.listed + [len(self.eccs) + j for j in range(self.n_slots)
                              if slot_tag(j) not in idle]
        first = len(self.eccs) + self.n_slots
        for j in range(self.n_scenarios):
            if scenario_tag(j) not in idle:
                rows += [first + j * len(self.eccs) + i for i in self.listed]
        return float(ripples[rows].max())

    def binding(self, g, lbg, ubg) -> str:
        """Name of the constraint block most violated at ``g`` ('' when none is)."""
        viol = np.maximum(lbg - g, g - ubg)
        viol[~np.isfinite(viol)] = 0
        if viol.size == 0 or viol.max() <= 1e-6:
            return ""
        return self.layout.name_of(self.layout.g, int(np.argmax(viol)))

    def active_set(self, problem, x, lam_x, lam_g, lbx, ubx, tol: float = 1e-7) -> list[dict]:
        """What binds at IPOPT's solution, with its sensitivity: each free length on a bound
        and each criterion whose rows carry a multiplier, as ``{name, kind, side,
        sensitivity, unit}``; ``sensitivity`` is d objective / d bound in the objective's
        units per ``unit`` of the designer's bound (IPOPT's multipliers, CasADi's sign
        convention: d f*/d bound = -λ; a criterion's rows share one bound, so they add up)."""
        lam_x, lam_g = np.asarray(lam_x).ravel(), np.asarray(lam_g).ravel()
        out = []
        sl = self.layout.find(self.layout.x, "lengths")
        for i, (k, s) in enumerate(zip(self.free, self.scale)):
            lam = lam_x[sl][i]
            if abs(lam) > tol:
                side = "lower" if lam < 0 else "upper"
                out.append({"name": f"{k} {side} bound", "kind": "bound", "side": side,
                            "sensitivity": float(-lam / s), "unit": "mm"})
        for name, criterion in self._criterion_blocks:
            lam = lam_g[self.layout.find(self.layout.g, name)]
            if np.max(np.abs(lam), initial=0.0) <= tol:
                continue
            side = "lower" if lam[np.argmax(np.abs(lam))] < 0 else "upper"
            per, unit = criterion.bound_per_unit(problem, side == "lower")
            out.append({"name": name, "kind": "constraint", "side": side,
                        "sensitivity": float(-lam.sum() * per), "unit": unit})
        return sorted(out, key=lambda a: -abs(a["sensitivity"]))

    def binding_scenarios(self, lam_g, held: Held, tol: float = 1e-7) -> tuple:
        """The offsets of the held scenario parts that bind at IPOPT's solution: a row of
        theirs carries a multiplier (a part that does not bind leaves its rows, equalities
        included, without one)."""
        lam = np.abs(np.asarray(lam_g).ravel())
        held = self._held(held)
        out = []
        for j in range(self.n_scenarios):
            if not held.scenario_active[j]:
                continue
            tag = scenario_tag(j)
            rows = [b for b in self.layout.g if b.name.endswith((f"[{tag}]", f"_{tag}]"))]
            if any(np.max(lam[b.slice], initial=0.0) > tol for b in rows):
                out.append(held.offsets[j])
        return tuple(out)

    def multiplier(self, lam_g, name: str) -> float:
        """d f*/d lower bound of block ``name`` (= -λ in CasADi's sign convention)."""
        return -float(np.asarray(lam_g).ravel()[self.layout.find(self.layout.g, name)][0])
