"""Multi-start optimisation results: the best local optimum, and whether the starts disagree.

A non-convex objective (the legible ``(1 + alpha) J1 - J0`` of eq. (6.15) on nonlinear dynamics)
can have several local minima; restarting iLQR from several initial guesses is the practical
check. :class:`MultiStart` keeps every run and says when converged runs ended at different
costs, i.e. when at least two distinct local minima were found.
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, repr=False)
class MultiStart:
    """Runs of one problem from several starts.

    ``runs`` the :class:`mutual.motion.trajopt.ILQRResult` of each start (None where it failed),
    ``labels`` a description of each start, ``rtol`` the relative tolerance (of the objective's
    magnitude) under which two costs count as the same minimum. Unpacks as ``(best, converged)``.
    """

    runs: tuple
    labels: tuple
    rtol: float = 1e-6

    @classmethod
    def from_runs(cls, runs, labels, rtol=1e-6):
        if not any(r is not None for r in runs):
            raise ValueError("no start converged; the task may be unbounded or badly scaled")
        if not (np.isfinite(rtol) and rtol > 0):
            raise ValueError(f"rtol must be a positive finite number, got {rtol!r}")
        return cls(tuple(runs), tuple(labels), float(rtol))

    @property
    def costs(self):
        """Final cost of each run (NaN where it failed)."""
        return np.array([np.nan if r is None else r.cost for r in self.runs])

    @property
    def best(self):
        """The converged run with the lowest cost."""
        return self.runs[int(np.nanargmin(self.costs))]

    @property
    def converged(self):
        """How many runs converged."""
        return int(sum(r is not None for r in self.runs))

    @property
    def minima(self):
        """The distinct local minima found, as sorted costs (costs within ``rtol`` times the
        objective's magnitude of each other count as one)."""
        costs = np.sort(self.costs[np.isfinite(self.costs)])
        scale = max([r.magnitude for r in self.runs if r is not None and np.isfinite(r.magnitude)] + [1e-300])
        distinct = [costs[0]]
        for c in costs[1:]:
            if c - distinct[-1] > self.rtol * scale:
                distinct.append(c)
        return np.array(distinct)

    @property
    def local_minima(self):
        """True when the runs disagree: they converged to at least two distinct local minima."""
        return len(self.minima) > 1

    def __iter__(self):
        yield self.best
        yield self.converged

    def __repr__(self):
        flag = f", {len(self.minima)} distinct local minima (runs disagree)" if self.local_minima else ", runs agree"
        return f"MultiStart(best cost {self.best.cost:.6g}, {self.converged}/{len(self.runs)} converged{flag})"
