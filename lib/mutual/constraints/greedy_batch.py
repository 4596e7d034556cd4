"""Greedy inference ranked by F (Section 2.4, eq. 2.25) for many demonstration sets on one world at once.

Scanning chapter 3's experiment takes thousands of greedy runs. All runs on one world share S, r, w,
T and the start, and F_{C+} = Z_{C+} / Z_{C0} at the start (eq. 2.25) depends on a run's
demonstrations only through which constraint sets it tries: each state candidate sits at its threshold
psi* (eq. 3.3), and runs whose demonstrations give the same psi* try the same sets. So
:class:`BatchWorld` backs each constraint set up once for every run that needs it (Algorithm 4,
the compiled backup of :mod:`.fast`) and caches its soft value at the start.
A run's demonstrations enter only through feasibility: a set rejects them exactly when a demonstrated
step is forbidden or reaches a state with no allowed continuation, found for every set of a round at
once by the boolean backup of :mod:`.feasibility` on bit-packed sets; the soft values are backed up
only for the sets that keep some run's demonstrations possible.

:func:`greedy_by_f` makes the choices of :func:`.inference.greedy_inference` with ``criterion="F"``
(the candidates of :func:`.candidates.constraint_candidates`, the same order and ties), for every run.
"""

from dataclasses import dataclass, field

import numpy as np

from . import fast
from .backup import backup_columns
from .chance import max_likelihood_thresholds
from .demonstrations import check_demonstrations


@dataclass(frozen=True, eq=False)
class RunData:
    """What greedy inference needs of one demonstration set: ``psi`` (X,) the thresholds of eq. 3.3,
    ``pairs`` (X, A) the demonstrated state-action pairs, ``reach`` (T, X) the states some demonstrated
    step t leads to with positive probability, and ``used`` (A,) the demonstrated actions."""

    psi: np.ndarray
    pairs: np.ndarray
    reach: np.ndarray
    used: np.ndarray

    @classmethod
    def of(cls, mdp, demos):
        check_demonstrations(mdp, demos)
        X, A, T = mdp.n_states, mdp.n_actions, mdp.horizon
        pairs = np.zeros((X, A), dtype=bool)
        pairs[demos.states[:, :-1], demos.actions] = True
        reach = np.zeros((T, X), dtype=bool)
        for t in range(demos.steps):
            rows = np.unique(demos.states[:, t] * A + demos.actions[:, t])
            reach[t] = np.asarray((mdp.transitions[rows] > 0).sum(axis=0)).ravel() > 0
        return cls(max_likelihood_thresholds(mdp, demos), pairs, reach, pairs.any(axis=0))

    def candidates(self):
        """The keys of :func:`.candidates.constraint_candidates`' candidates in its order: ("state", x, psi*(x))
        for every state, then ("action", a) for every action never demonstrated (the others reject the
        demonstrations)."""
        return ([("state", x, float(p)) for x, p in enumerate(self.psi)]
                + [("action", a) for a in np.flatnonzero(~self.used).tolist()])


@dataclass(eq=False)
class BatchWorld:
    """One MDP whose start is a single state, with a cache of the soft value V_{C,0} at the start of every
    set of forbidden actions backed up on it (keyed by the packed (X, A) mask)."""

    mdp: object
    value: dict = field(default_factory=dict)
    backed_up: int = 0

    def __post_init__(self):
        starts = np.flatnonzero(self.mdp.initial)
        if starts.size != 1:
            raise ValueError("mdp: the batched greedy needs a single start state (mdp.initial a point mass)")
        if fast.stencil_form(self.mdp) is None:
            raise ValueError("mdp: the batched greedy needs an MDP in stencil form (a grid; mutual.constraints.fast)")
        self.start = int(starts[0])
        self.S = self.mdp.dense_transitions()
        self.offsets, P = fast.stencil_form(self.mdp)
        self.reaches = P > 0
        self._keys = {}

    def key_forbidden(self, key):
        """The actions one candidate forbids (X, A): S(x, a, x_bar) > psi (eq. 3.1), or an action everywhere."""
        if key not in self._keys:
            if key[0] == "state":
                out = self.S[:, :, key[1]] > key[2]
            else:
                out = np.zeros(self.S.shape[:2], dtype=bool)
                out[:, key[1]] = True
            self._keys[key] = out
        return self._keys[key]

    def forbidden_of(self, keys):
        """The actions the constraint set ``keys`` forbids (X, A), besides those the MDP does not offer."""
        out = np.zeros(self.S.shape[:2], dtype=bool)
        for key in keys:
            out |= self.key_forbidden(key)
        return out

    def evaluate(self, forbidden):
        """Back up every set of forbidden actions of ``forbidden`` (a list of (X, A) arrays) not yet cached
        (Algorithm 4, compiled, in blocks); returns their soft values V_{C,0} at the start. Sets that forbid
        the same actions share one backup."""
        keys = [np.packbits(f).tobytes() for f in forbidden]
        new = {k: f for k, f in zip(keys, forbidden) if k not in self.value}
        if new:
            stack = np.stack(list(new.values()), axis=2)
            V0, _ = backup_columns(self.mdp, lambda block: ~stack[:, :, block], stack.shape[2], None, "jax")
            self.value.update(zip(new, V0[self.start].tolist()))
            self.backed_up += len(new)
        return np.array([self.value[k] for k in keys])

    def rejections(self, forbidden, runs):
        """For constraint sets ``forbidden`` (X, A, n) and ``runs`` [(RunData, columns)]: for each run, which
        of its columns reject its demonstrations (a demonstrated pair forbidden, or a demonstrated step
        reaching a dead state: no allowed continuation, V = -inf, eq. 2.21). The -inf pattern of
        :mod:`.feasibility`, for 64 sets per machine word."""
        words = _pack(forbidden | ~self.mdp.allowed[:, :, None])
        dead = self._dead(words)
        out = []
        for run, columns in runs:
            bad = np.bitwise_or.reduce(words[run.pairs], axis=0)
            if dead is not None:
                bad |= np.bitwise_or.reduce(dead[1:][run.reach[:-1]], axis=0)
            bits = np.unpackbits(bad.view(np.uint8), bitorder="little").astype(bool)
            out.append(bits[np.asarray(columns, dtype=int)])
        return out

    def _dead(self, words):
        """dead[t, x]: the sets (bits) under which no trajectory from x at time t satisfies them, t = 0..T-1;
        None when no set leaves any state without an action. Dead sets only grow back in time."""
        T, (X, _, W) = self.mdp.horizon, words.shape
        last = np.bitwise_and.reduce(words, axis=1)
        if not last.any():
            return None
        dead = np.zeros((T, X, W), dtype=np.uint64)
        dead[T - 1] = last
        lo, hi = max(0, -min(self.offsets)), max(0, max(self.offsets))
        zero = np.uint64(0)
        for t in range(T - 2, -1, -1):
            padded = np.pad(dead[t + 1], ((lo, hi), (0, 0)))
            bad = words.copy()
            for j, o in enumerate(self.offsets):
                bad |= np.where(self.reaches[:, :, j, None], padded[lo + o: lo + o + X][:, None, :], zero)
            dead[t] = np.bitwise_and.reduce(bad, axis=1)
            if np.array_equal(dead[t], dead[t + 1]):
                dead[:t] = dead[t]
                break
        return dead


def _pack(bits):
    """Boolean (X, A, n) as uint64 words (X, A, ceil(n / 64)), set k in bit k % 64 of word k // 64."""
    packed = np.packbits(bits, axis=2, bitorder="little")
    pad = -packed.shape[2] % 8
    packed = np.pad(packed, ((0, 0), (0, 0), (0, pad)))
    return np.ascontiguousarray(packed).view(np.uint64)


@dataclass
class GreedyRun:
    """One run's greedy history: ``chosen`` candidate keys, ``log_f`` of each choice, ``first_round`` the
    round-1 log F of every candidate key (nan: rejects the demonstrations) and ``stop`` why it ended."""

    chosen: list = field(default_factory=list)
    log_f: list = field(default_factory=list)
    first_round: dict = field(default_factory=dict)
    stop: str = "rounds"


def greedy_by_f(world, runs, rounds, until=None):
    """Greedy inference ranked by F on ``world`` (:class:`BatchWorld`) for every :class:`RunData` of ``runs``:
    each round, every candidate that keeps the run's demonstrations possible is scored by F = Z_{C+}/Z_{C0}
    at the start, and the smallest is added (ties: the first in candidate order). ``until(i, chosen)`` ends
    run i once it returns True. Returns one :class:`GreedyRun` per run."""
    out = [GreedyRun() for _ in runs]
    keys = [run.candidates() for run in runs]
    for _ in range(rounds):
        active = [i for i, r in enumerate(out) if r.stop == "rounds"]
        if not active:
            break
        sets, asks = {}, []
        for i in active:
            base = frozenset(out[i].chosen)
            base_forbidden = world.forbidden_of(base)
            sets.setdefault(base, base_forbidden)
            todo = [k for k in keys[i] if k not in base]
            for k in todo:
                sets.setdefault(base | {k}, base_forbidden | world.key_forbidden(k))
            asks.append((i, base, todo))
        order = {s: n for n, s in enumerate(sets)}
        rejected = world.rejections(np.stack(list(sets.values()), axis=2),
                                    [(runs[i], [order[base | {k}] for k in todo]) for i, base, todo in asks])
        wanted = [s for (i, base, todo), r in zip(asks, rejected) for k, bad in zip(todo, r) if not bad
                  for s in (base, base | {k})]
        value = dict(zip(wanted, world.evaluate([sets[s] for s in wanted]))) if wanted else {}
        for (i, base, todo), bad in zip(asks, rejected):
            scores = {k: np.nan if b else value[base | {k}] - value[base] for k, b in zip(todo, bad)}
            if not out[i].chosen:
                out[i].first_round = scores
            finite = [(v, n) for n, v in enumerate(scores.values()) if np.isfinite(v)]
            if not finite:
                out[i].stop = "no feasible candidate"
                continue
            best_f, n = min(finite)
            out[i].chosen.append(todo[n])
            out[i].log_f.append(best_f)
            if until is not None and until(i, out[i].chosen):
                out[i].stop = "until"
    return out
