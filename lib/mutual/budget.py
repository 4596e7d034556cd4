"""The memory and time of a request, estimated from its sizes before anything is allocated.

Each estimator below turns the sizes of one kind of request (cells, a horizon, levels, demonstrations,
distractors, value-function members) into an :class:`Estimate`: the peak memory in bytes, the time
in seconds, what dominates them and the knob that makes them smaller. :func:`check` compares an
estimate with the memory available now (:func:`available_bytes`) and with a time limit when one is
stated, and raises :class:`TooLarge` (a ValueError) that gives the estimate in GiB and minutes, the
limit, the knob, and how to go ahead anyway. Every command of ``mutual`` checks its request up front,
and the library's entry points that can be asked for a huge size check theirs.

Limits. :func:`limits` states them for a block of code: ``minutes`` (None, the library's default: no
time limit) and ``allow_large`` (go ahead whatever the estimate). The command line runs every command
inside ``limits(minutes=command_line_minutes(), allow_large=args.allow_large)``: it refuses work
estimated above ``$MUTUAL_MAX_MINUTES`` (default :data:`MINUTES`) or above the memory available, and
``--allow-large`` goes ahead. In Python, pass ``allow_large=True`` to an entry point, or wrap the
calls in ``with budget.limits(allow_large=True):``.

Calibration. The times per unit (the ``*_SECONDS`` constants) were measured on the 2-core development
machine (Intel, 2.3 GHz, shared with other work), one core per task, on instances small enough to take
seconds: ``python bench/calibrate_budget.py`` reruns those instances and prints the measured time next
to the estimate, so a constant can be refitted on another machine. The memory per unit counts the
arrays a computation holds at its peak (checked against tracemalloc's peak in ``tests/test_budget.py``).
An estimate is meant to be right within a factor of a few: enough to refuse a request that would take
hours or exhaust the memory, never a promise. Estimating costs arithmetic only, no allocation.
"""

import math
import os
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

GIB = 2 ** 30
MINUTES = 30                     # the command line's time limit (``$MUTUAL_MAX_MINUTES`` overrides it)
MINUTES_ENV = "MUTUAL_MAX_MINUTES"

# seconds per unit, measured (module docstring)
RK4_SECONDS = 7e-7               # one RK4 substep of one state, vectorised numpy (a named system)
ANOVA_PAIR_SECONDS = 6e-3        # one pair of levels: Tukey's studentized range p and a paired t-test
CONTINUOUS_BACKUP_SECONDS = 1e-8  # one (step, cell, control, candidate region) of continuous inference
SOFT_BACKUP_SECONDS = 5e-9       # one (step, successor entry) of a soft Bellman backup over a sparse S
LQ_STEP_SECONDS = 7e-5           # one step of one hypothesis of the legible LQ solve and its evidence
ILQR_STEP_SECONDS = 5e-4         # one step of one hypothesis of the Dubins car's legible iLQR
HJ_NODE_SECONDS = 2.3e-5         # one grid node of one value function (hj-reachability, to convergence)
CLOSED_FORM_NODE_SECONDS = 2e-7  # one grid node of one value function in closed form
PARTICIPANT_SECONDS = 0.32       # one simulated participant of the power sweep (full grid, 60-s trials)
SAMPLE_SIZE_SECONDS = 5e-4       # one sample size of G*Power's table: its noncentral F power (scipy)
GRID_BACKUP_SECONDS = 4e-8       # one (round, candidate, step, state, action) of gridworld inference

CSV_BYTE_SECONDS = 3e-7          # one byte of a CSV file: split into lines, checked, parsed into text cells
CSV_COLUMN_SECONDS = 1e-4        # one column of a CSV table made into a pandas column (any number of rows)
ANOVA_ROW_SECONDS = 1e-5         # one row of a study table: its names checked, its value parsed, into the cells

# bytes per unit held at the peak
SPARSE_ENTRY_BYTES = 64          # one entry of S while it is assembled (row, column, weight; CSR copies)
CONTINUOUS_PAIR_BYTES = 1536     # one (cell, control) pair during continuous inference (S, masks, backups)
LQ_STEP_BYTES = 400              # one step of one hypothesis of the legible LQ solve (gains, motions, factors)
ROW_BYTES = 200                  # one recorded state kept as a Python row (array view and list slot)
CSV_BYTE_BYTES = 12              # one byte of a CSV file: its bytes, its text, its lines and their cells as text

_LIMITS = ContextVar("mutual_budget_limits", default=(None, False, None, None))
NOTICE_SECONDS = 60              # a request estimated above this (or NOTICE_BYTES) is said before it starts
NOTICE_BYTES = 2 * GIB


@dataclass(frozen=True)
class Estimate:
    """What a request will hold at its peak (``bytes``) and how long it will take (``seconds``), ``what``
    the request is, and ``knob``: what makes it smaller."""
    what: str
    bytes: float
    seconds: float
    knob: str

    def __str__(self):
        return f"{self.what}: about {memory(self.bytes)} of memory and {duration(self.seconds)}"


class TooLarge(ValueError):
    """A request refused before it started: its :class:`Estimate` exceeds the memory available or the time limit."""

    def __init__(self, estimate, reason):
        self.estimate, self.reason = estimate, reason
        super().__init__(f"{estimate} ({reason}); {estimate.knob}, or {_go_ahead()}")


def memory(n_bytes):
    """``n_bytes`` in GiB (MiB below 1 GiB), three significant digits."""
    n_bytes = float(n_bytes)
    if n_bytes < GIB:
        return f"{n_bytes / 2 ** 20:.3g} MiB"
    return f"{n_bytes / GIB:.3g} GiB" if n_bytes < 1e6 * GIB else f"{n_bytes / GIB:.2e} GiB"


def duration(seconds):
    """``seconds`` in the largest fitting unit: s, minutes, hours, days or years."""
    for unit, size in (("years", 3.15e7), ("days", 86400.0), ("hours", 3600.0), ("minutes", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}" if seconds / size < 1e6 else f"{seconds / size:.2e} {unit}"
    return f"{seconds:.2g} s"


def available_bytes():
    """The memory this process may still allocate: the kernel's ``MemAvailable``, capped by the cgroup's limit
    (a container's) when there is one; the physical memory when neither can be read."""
    found = []
    try:
        with open("/proc/meminfo") as info:
            for line in info:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
                    break
    except (OSError, ValueError, IndexError):
        pass
    for limit, usage in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                         ("/sys/fs/cgroup/memory/memory.limit_in_bytes", "/sys/fs/cgroup/memory/memory.usage_in_bytes")):
        try:
            with open(limit) as a, open(usage) as b:
                cap = a.read().strip()
                if cap != "max" and int(cap) < 2 ** 60:
                    found.append(max(0, int(cap) - int(b.read().strip())))
                break
        except (OSError, ValueError):
            continue
    if not found:
        try:
            found.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            return math.inf
    return float(min(found))


def command_line_minutes(environ=os.environ):
    """The command line's time limit in minutes: ``$MUTUAL_MAX_MINUTES`` (a positive finite number) or
    :data:`MINUTES`."""
    text = environ.get(MINUTES_ENV, "").strip()
    if not text:
        return MINUTES
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (0 < value < math.inf):
        raise ValueError(f"${MINUTES_ENV} = {text!r}: must be a positive finite number of minutes (--allow-large "
                         "goes ahead whatever the estimate)")
    return value


@contextmanager
def limits(minutes=None, allow_large=False, flag=None, say=None):
    """State the limits for the checks made inside the block (module docstring). ``flag``: how the
    refusal tells the user to go ahead (the command line's ``--allow-large``); ``say``: called with one line
    for each request let through whose estimate exceeds NOTICE_SECONDS or NOTICE_BYTES, before it starts, unless
    one said before in the block needs as much time and memory (a part of it, or a repeat)."""
    token = _LIMITS.set((minutes, bool(allow_large), flag, None if say is None else _larger(say)))
    try:
        yield
    finally:
        _LIMITS.reset(token)


def _larger(say):
    """``say(estimate, line)`` for an estimate larger (in time and memory) than every one said before."""
    said = []

    def larger(estimate, line):
        if all(estimate.seconds > e.seconds or estimate.bytes > e.bytes for e in said):
            said.append(estimate)
            say(line)
    return larger


def _state():
    return _LIMITS.get()


def _go_ahead():
    flag = _state()[2]
    return f"pass {flag} to go ahead anyway" if flag else "pass allow_large=True to go ahead anyway"


def check(estimate, allow_large=None, minutes=None):
    """Raise :class:`TooLarge` when ``estimate`` needs more memory than :func:`available_bytes` or more time
    than ``minutes`` (default: the limit in force, :func:`limits`); ``allow_large`` (default: as the limits in
    force say) lets it through. Returns the estimate."""
    stated, allowed, _, say = _state()
    minutes = stated if minutes is None else minutes
    free = available_bytes()
    if not (allowed if allow_large is None else allow_large):
        if estimate.bytes > free:
            raise TooLarge(estimate, f"{memory(free)} are available")
        if minutes is not None and estimate.seconds > 60 * minutes:
            raise TooLarge(estimate, f"the limit is {minutes:g} minutes")
    if say is not None and (estimate.seconds > NOTICE_SECONDS or estimate.bytes > NOTICE_BYTES):
        limit = f", the limit is {minutes:g} minutes" if minutes is not None else ""
        say(estimate, f"{estimate} (estimated before starting; {memory(free)} are available{limit})")
    return estimate


def _product(sizes):
    return math.prod(float(n) for n in sizes)


def _x(sizes):
    return " x ".join(f"{int(n):,}" for n in sizes)


# -- the estimators, one per kind of request ---------------------------------------------------------------

def array(shape, itemsize=8, what="an array", knob="ask for less"):
    """One dense array of ``shape`` (its size, no time)."""
    return Estimate(f"{what} ({_x(shape)})", _product(shape) * itemsize, 0.0, knob)


def anova(levels, subjects, rows=None):
    """:func:`mutual.study.rm_anova` and every pair of levels (Tukey and Holm), ``levels`` x ``subjects`` cells
    from ``rows`` rows of long data (default: one per cell)."""
    pairs = levels * (levels - 1) / 2
    rows = float(levels) * subjects if rows is None else float(rows)
    return Estimate(f"the repeated-measures ANOVA of {int(levels):,} levels x {int(subjects):,} subjects "
                    f"({int(pairs):,} pairs of levels, {int(rows):,} rows)",
                    8.0 * levels * subjects * 4 + 600.0 * pairs + ROW_BYTES * rows,
                    ANOVA_PAIR_SECONDS * pairs + ANOVA_ROW_SECONDS * rows,
                    "analyse fewer levels or subjects (--levels, or select rows with --where)")


def csv_table(name, size, columns):
    """Reading a CSV file of ``size`` bytes into a table of ``columns`` columns (:func:`mutual.inputs.read_csv`)."""
    return Estimate(f"reading {name} ({memory(size)}, {int(columns):,} columns)", CSV_BYTE_BYTES * float(size),
                    CSV_BYTE_SECONDS * size + CSV_COLUMN_SECONDS * columns,
                    "read a smaller file (split it, or keep only the columns and rows needed)")


def discretization(cells, controls, samples, scheme="sample", substeps=4, ndim=None):
    """S(x, a, x') of a continuous system (:func:`mutual.constraints.continuous.discretize`): ``cells`` per
    coordinate, ``controls`` in the set, ``samples`` per cell (scheme "sample") or the cell centre ("barycentric")."""
    d = len(cells) if ndim is None else ndim
    X, points = _product(cells), float(samples) if scheme == "sample" else 1.0
    successors = min(points, 3.0 ** d) if scheme == "sample" else d + 1.0
    chunk = min(X, 2048.0) * controls * points * d * 8.0 * 6
    return Estimate(f"discretizing {_x(cells)} cells x {int(controls)} controls x {int(points):,} points",
                    X * controls * successors * SPARSE_ENTRY_BYTES + chunk,
                    X * controls * points * substeps * RK4_SECONDS,
                    "use fewer cells (--cells or [state] cells) or fewer samples ([discretization] samples)")


def candidate_regions(cells, families=("bound",), every=2, radii=3, half_widths=2):
    """How many candidate regions the ``families`` propose on a grid of ``cells`` (before any is dropped)."""
    count = 0.0
    if "bound" in families:
        count += 2.0 * sum(float(n) - 1 for n in cells)
    plane = math.ceil(float(cells[0]) / every) * math.ceil(float(cells[min(1, len(cells) - 1)]) / every)
    count += plane * radii * ("disk" in families) + plane * half_widths * ("box" in families)
    return count + _product(cells) * ("cell" in families)


def continuous_inference(cells, controls, samples, horizon, scheme="sample", substeps=4, families=("bound",),
                         every=2, radii=3, half_widths=2):
    """Discretization and greedy inference of chance constraints on a continuous system (infer-continuous)."""
    disc = discretization(cells, controls, samples, scheme, substeps)
    X = _product(cells)
    regions = candidate_regions(cells, families, every, radii, half_widths)
    seconds = CONTINUOUS_BACKUP_SECONDS * horizon * X * controls * regions
    points = f" x {int(samples):,} samples" if scheme == "sample" else ""
    return Estimate(f"constraint inference on {_x(cells)} cells x {int(controls)} controls{points} over "
                    f"{int(horizon):,} steps ({int(regions):,} candidate regions)", max(disc.bytes, X * controls * CONTINUOUS_PAIR_BYTES),
                    disc.seconds + seconds, "use fewer cells (--cells or [state] cells), a shorter horizon ([time] "
                    "horizon), fewer samples ([discretization] samples) or fewer candidate families")


def soft_demonstrator(cells, controls, horizon, substeps=4):
    """A Boltzmann demonstrator on a grid of ``cells`` (barycentric S and the soft values of every step)."""
    disc = discretization(cells, controls, 1, "barycentric", substeps)
    X, entries = _product(cells), _product(cells) * controls * (len(cells) + 1)
    return Estimate(f"a soft demonstrator on {_x(cells)} cells x {int(controls)} controls over {int(horizon):,} steps",
                    disc.bytes + 8.0 * (horizon + 1) * X + 10.0 * X * controls,
                    disc.seconds + SOFT_BACKUP_SECONDS * horizon * entries,
                    "use fewer demonstrator cells ([simulate] fine_cells) or a shorter horizon ([time] horizon)")


def rollouts(n, steps, dim, controls=1, substeps=4, record_every=1, plans=0, plan_steps=0):
    """``n`` simulated trajectories of ``steps`` steps (each step checks ``controls`` candidate controls; an MPPI
    demonstrator integrates ``plans`` samples of ``plan_steps`` steps per decision)."""
    integrations = n * steps * (controls * substeps + plans * plan_steps * substeps)
    rows = n * (steps * record_every + 1)
    fewer = "fewer demonstrations (--n or [simulate] n) or a shorter horizon ([time] horizon)"
    if plans:
        what = (f"{int(n):,} demonstrations of {int(steps):,} steps, each step planned over {int(plans):,} MPPI "
                f"samples of {int(plan_steps):,} steps")
        knob = f"ask for fewer MPPI samples ([simulate] samples), shorter plans ([simulate] plan_steps), {fewer}"
    else:
        what, knob = f"{int(n):,} demonstrations of {int(steps):,} steps", f"ask for {fewer}"
    return Estimate(what, rows * (ROW_BYTES + 8.0 * dim) + 8.0 * n * max(plans, 1) * max(plan_steps, 1) * 3,
                    integrations * RK4_SECONDS, knob)


def gridworld_inference(states, actions, horizon, rounds, demonstrations=0):
    """Greedy inference on a gridworld: every state and action a candidate, each round one backup per candidate."""
    candidates = states + actions
    return Estimate(f"constraint inference on {int(states):,} states x {int(actions)} actions over "
                    f"{int(horizon):,} steps ({int(rounds)} rounds)",
                    8.0 * (2 * (horizon + 1) * states * actions + 9 * states * actions * 2) + 16.0 * demonstrations,
                    GRID_BACKUP_SECONDS * rounds * candidates * horizon * states * actions,
                    "use a smaller world, a shorter horizon or fewer --rounds")


def demonstrations(n, steps):
    """``n`` demonstrations of ``steps`` steps in a gridworld (state and action per step)."""
    return Estimate(f"{int(n):,} demonstrations of {int(steps):,} steps", 100.0 * n * (steps + 1),
                    2e-6 * n * steps, "ask for fewer demonstrations (--n)")


def legible(steps, hypotheses, dynamics="single-integrator"):
    """The legible and predictable motions of ``steps`` steps against ``hypotheses`` goals (the goal and the
    distractors): an LQ solve per hypothesis, or the Dubins car's iLQR."""
    per_step = LQ_STEP_SECONDS if dynamics == "single-integrator" else ILQR_STEP_SECONDS
    return Estimate(f"legible motion of {int(steps):,} steps against {int(hypotheses):,} goals",
                    LQ_STEP_BYTES * steps * (hypotheses + 1), per_step * steps * hypotheses,
                    "use fewer steps or fewer distractors")


#: the nodes of the command line's quick grid (mutual.supervision.QUICK_GRID; a test checks they agree)
QUICK_GRID_NODES = 41 * 41 * 24


def value_library(members, shape, computed=None, method="hj"):
    """A library of ``members`` avoid value functions on a grid of ``shape`` nodes (float32, solver state), of
    which ``computed`` (default all) are solved: by hj-reachability (``method="hj"``) or in closed form. The
    knob offers the quick grid only to a request on a larger grid."""
    nodes, computed = _product(shape), members if computed is None else computed
    per_node = HJ_NODE_SECONDS if method == "hj" else CLOSED_FORM_NODE_SECONDS
    knob = "use fewer library members (--w-max)" + (" or a smaller grid (--grid quick)"
                                                    if nodes > QUICK_GRID_NODES else "")
    return Estimate(f"{int(members):,} value functions on {_x(shape)} nodes ({int(computed):,} to compute)",
                    4.0 * nodes * (members + 12), per_node * nodes * computed, knob)


def sample_sizes(count, what="--n"):
    """G*Power's analytic power at ``count`` sample sizes (``what``: as the user asked for them), a row each."""
    return Estimate(f"{int(count):,} sample sizes ({what})", 200.0 * count, SAMPLE_SIZE_SECONDS * count,
                    "list fewer sample sizes (--n a:b:step with a larger step)")


def power_simulation(cohorts, participants, workers=1):
    """``cohorts`` simulated cohorts of ``participants`` analysed participants, on ``workers`` processes."""
    people = float(cohorts) * participants
    return Estimate(f"{int(cohorts):,} simulated cohorts of {int(participants):,} participants",
                    2 * 400.0 * people, PARTICIPANT_SECONDS * people / max(1, workers),
                    "simulate fewer cohorts (--cohorts) or smaller ones (--n)")
