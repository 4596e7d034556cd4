"""Figures of the replication planner: power curves with their Monte Carlo intervals, and
the Explore view of the analytic power (a ``matplotlib.figure.Figure``, no pyplot)."""

import numpy as np
from matplotlib.figure import Figure

from ..style import PALETTE
from .power import rm_anova_power, rm_anova_sample_size

TARGETS = (0.8, 0.9)


def plot_targets(ax, targets=TARGETS):
    """Dotted horizontal lines at the target powers."""
    for t in targets:
        ax.axhline(t, color="0.6", lw=0.8, ls=":", zorder=0)
        ax.text(1.0, t, f" {t:.0%}", transform=ax.get_yaxis_transform(), va="center", fontsize=7, color="0.4")


def plot_simulated_power(ax, table, test, label, color, marker="o", offset=0.0):
    """Monte Carlo power of ``test`` against n from a :func:`mutual.study.cohort_power.power_table`,
    with its Wilson 95% interval as error bars."""
    rows = table[table["test"] == test].sort_values("n")
    if rows.empty:
        raise ValueError(f"the table has no rows for test {test!r}; tests: {sorted(table['test'].unique())}")
    y = rows["power"].to_numpy()
    err = np.maximum(np.vstack([y - rows["ci_low"].to_numpy(), rows["ci_high"].to_numpy() - y]), 0.0)  # rounding at 0 and 1
    ax.errorbar(rows["n"].to_numpy() + offset, y, yerr=err, fmt=marker, ms=3.5, lw=0.9, capsize=2, color=color,
                label=label)


def plot_analytic_power(ax, n_values, powers, label, color, ls="-"):
    """An analytic (or otherwise exact) power curve."""
    ax.plot(n_values, powers, ls=ls, color=color, lw=1.4, label=label)


def finish_power_axes(ax, title, n_values):
    ax.set_xlabel("participants analysed, N")
    ax.set_ylabel("power (probability of p < 0.05)")
    ax.set_ylim(0, 1.02)
    ax.set_xlim(min(n_values) - 1, max(n_values) + 1)
    ax.set_title(title, fontsize=9)
    plot_targets(ax)


def power_curve_view(f=0.4, rho=0.5, epsilon=1.0, alpha=0.05, m=3, n_max=40):
    """Explore: the analytic power of the one-way repeated-measures ANOVA (G*Power, within factors)
    against the number of subjects, for G*Power's effect size ``f``, correlation ``rho`` among the
    repeated measures, sphericity correction ``epsilon`` and level ``alpha``, with the sample sizes
    that reach 80% and 90% power marked. The thesis's study had N = 11, m = 3."""
    n_max = int(n_max)
    if n_max < 3:
        raise ValueError(f"n_max must be at least 3, got {n_max!r}")
    n = np.arange(2, n_max + 1)
    power = np.array([rm_anova_power(int(k), m, f=f, rho=rho, epsilon=epsilon, alpha=alpha) for k in n])
    fig = Figure(figsize=(5.6, 3.6))
    ax = fig.add_subplot()
    ax.plot(n, power, color=PALETTE["blue"], lw=1.6, label=f"f = {f:g}, rho = {rho:g}, epsilon = {epsilon:g}")
    ax.axvline(11, color=PALETTE["vermillion"], lw=0.9, ls="--", label="the thesis's N = 11")
    for target, style in zip(TARGETS, ("-.", ":")):
        try:
            need = rm_anova_sample_size(target, m, f=f, rho=rho, epsilon=epsilon, alpha=alpha, n_max=100_000)
        except ValueError:
            need = None
        text = f"N = {need} for {target:.0%}" if need else f"{target:.0%} out of reach"
        if need and need <= n_max:
            ax.plot([need], [rm_anova_power(need, m, f=f, rho=rho, epsilon=epsilon, alpha=alpha)], "o",
                    color=PALETTE["green"], ms=5)
        ax.plot([], [], " ", label=text)
    ax.set_xlabel("subjects, N")
    ax.set_ylabel("power")
    ax.set_ylim(0, 1.02)
    ax.set_title(f"Analytic power, one-way RM-ANOVA, m = {m}, alpha = {alpha:g}", fontsize=9)
    plot_targets(ax)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return fig
