"""Figures of chapter 8's cycle, drawn from computed runs; each function returns a
``matplotlib.figure.Figure`` (no pyplot state), labelled as simulated."""

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle, FancyArrowPatch

from ..constraints import GRID_ACTIONS, plot_states
from ..style import PALETTE
from ..supervision import avoid_value_closed_form, rotate_to_heading

ROBOT_COLOURS = {"plain": "#8c8c8c", "legible": PALETTE["green"], "H0": PALETTE["black"], "H1": "#8c8c8c"}


def _mark_constraints(ax, grid, truth, inferred):
    """Open circles on the true cells, red crosses on the inferred ones; actions listed in text."""
    for s in truth.states:
        ax.plot(*grid.coords(s), marker="o", mfc="none", mec="white", ms=11, mew=1.2)
    cells = [i for k, i in inferred if k == "state"]
    for s in cells:
        ax.plot(*grid.coords(s), marker="x", color=PALETTE["vermillion"], ms=8, mew=2.2, ls="none")
    actions = [GRID_ACTIONS[i] for k, i in inferred if k == "action"]
    ax.text(0.0, -0.21, "inferred actions: " + (", ".join(actions) or "none"), transform=ax.transAxes,
            fontsize=6.5, va="top")


def cycle_figure(discrete, continuous):
    """Figure 8.1 from the computed runs: two loops (rows), each learn -> act -> show (columns).

    ``discrete``: ``grid1``, ``grid2`` (Gridworlds), ``truth`` (ConstraintSet), ``inferred`` (labels),
    ``visits1`` (X,) demonstration visits of task 1, ``robot_visits`` (X,) expected visits of the robot
    in task 2, ``act`` (compare_robots frame), ``posterior`` {robot: (T+1,)}.
    ``continuous``: ``interventions`` (n, 3), ``fit`` (SupervisorFit), ``supervisor`` (NoisySupervisor),
    ``fp`` (false_positive_study frame), ``posterior`` {robot: (N+1,)}, ``dt``, ``crossing`` (s; not drawn
    when infinite), optionally ``other_run`` {label: (dt, posterior (N+1,))} drawn dashed beside it.
    """
    fig = Figure(figsize=(10.5, 7.4))
    axes = fig.subplots(2, 3, gridspec_kw={"wspace": 0.45, "hspace": 0.75})
    fig.subplots_adjust(bottom=0.14, top=0.86)
    d, c = discrete, continuous
    ax = axes[0, 0]
    plot_states(ax, d["grid1"], np.log10(d["visits1"] + 1e-3), vmin=-3, vmax=1,
                title="1 Learn: constraints from the human's\ndemonstrations (task 1 + task 2)\n(shade: log10 visits of task 1's demonstrator)")
    _mark_constraints(ax, d["grid1"], d["truth"], d["inferred"])
    ax = axes[0, 1]
    plot_states(ax, d["grid2"], np.log10(d["robot_visits"] + 1e-3), vmin=-3, vmax=1,
                title="2 Act: the robot in task 2 with its\nlearned constraints (shade: log10 expected visits)")
    _mark_constraints(ax, d["grid2"], d["truth"], d["inferred"])
    act = d["act"].set_index("robot")["p_break"]
    pairs = [f"{k}: {v:.2f}" for k, v in act.items()]
    ax.text(0.0, -0.28, "P(break a true constraint), exact:\n" + "\n".join(", ".join(pairs[i:i + 2]) for i in range(0, len(pairs), 2)),
            transform=ax.transAxes, fontsize=6.5, va="top")
    ax = axes[0, 2]
    for name, post in d["posterior"].items():
        ax.plot(np.arange(len(post)), post, color=ROBOT_COLOURS.get(name), label=f"{name} robot")
    ax.axhline(0.95, color=PALETTE["vermillion"], lw=0.8, ls="--", label="95%")
    ax.set(xlabel="step t of task 2", ylabel="mean P(H1 | x, a so far)", ylim=(0.45, 1.0),
           title="3 Show: the human observer's belief\nthat the robot respects the constraints")
    ax.legend(fontsize=6.5, loc="lower right")
    ax = axes[1, 0]
    _supervisor_panel(ax, c["interventions"], c["fit"], c["supervisor"])
    ax.set_title("1 Learn: the supervisor's safe set\nfrom their interventions", fontsize=9)
    ax = axes[1, 1]
    fp = c["fp"]
    ax.bar(np.arange(len(fp)), fp["p_false_positive"], color=PALETTE["sky"],
           yerr=[fp["p_false_positive"] - fp["low"], fp["high"] - fp["p_false_positive"]], capsize=3)
    ax.set_xticks(np.arange(len(fp)), fp["controller"], fontsize=7, rotation=15)
    ax.set(ylabel="P(false-positive intervention)", ylim=(0, 1.05),
           title="2 Act: avoiding at alpha = mu + 2 sigma\n(error bars: 95% bootstrap CI)")
    ax = axes[1, 2]
    for name, post in c["posterior"].items():
        ax.plot(c["dt"] * np.arange(len(post)), post, color=ROBOT_COLOURS.get(name), label=f"{name} robot")
    ax.axhline(0.95, color=PALETTE["vermillion"], lw=0.8, ls="--")
    for label, (dt, post) in c.get("other_run", {}).items():
        ax.plot(dt * np.arange(len(post)), post, color=PALETTE["black"], lw=0.8, ls="--", label=label)
    if np.isfinite(c["crossing"]):
        ax.axvline(c["crossing"], color=PALETTE["black"], lw=0.8, ls=":", label="an ignorant robot\nreaches the supervisor's level")
    ax.set(xlabel="time (s)", ylabel="P(H1 | motion so far)", ylim=(0.45, 1.0),
           title="3 Show: the supervisor's belief that\nthe robot avoids their safe set")
    ax.legend(fontsize=6, loc="center right")
    for row, label in ((0, "discrete loop: gridworld (ch. 2-3, 6)"), (1, "continuous loop: supervision (ch. 4-5, 7)")):
        fig.text(0.01, 0.74 - 0.46 * row, label, rotation=90, va="center", fontsize=9, fontweight="bold")
        for col in (0, 1):
            a, b = axes[row, col].get_position(), axes[row, col + 1].get_position()
            fig.patches.append(FancyArrowPatch((a.x1 + 0.005, a.y0 + a.height / 2), (b.x0 - 0.045, b.y0 + b.height / 2),
                                               transform=fig.transFigure, arrowstyle="-|>", mutation_scale=14,
                                               color=PALETTE["orange"], lw=2))
    left, right = axes[1, 0].get_position(), axes[1, 2].get_position()
    fig.patches.append(FancyArrowPatch((right.x0 + right.width / 2, 0.045), (left.x0 + left.width / 2, 0.045),
                                       transform=fig.transFigure, arrowstyle="-|>", mutation_scale=14,
                                       color=PALETTE["orange"], lw=2))
    fig.text(0.5, 0.012, "the cycle closes: what the human sees shapes their next interventions and demonstrations",
             ha="center", fontsize=8, color=PALETTE["orange"])
    fig.suptitle("Figure 8.1, computed: machines learn human safety models, robots show what they learned (simulated)",
                 fontsize=10)
    return fig


def _supervisor_panel(ax, interventions, fit, supervisor, k=2.0):
    """Interventions rotated to heading 0 over the fitted value function's alpha = mu + k sigma contour
    and the supervisor's own intervention level (true, unknown to the robot)."""
    canon = rotate_to_heading(interventions, 0.0)
    x, y, v = fit.value_fn.theta_slice(0.0, resolution=121)
    _, _, vs = supervisor.value_fn.theta_slice(0.0, resolution=121)
    ax.contour(x, y, v, levels=[fit.level(k)], colors=[PALETTE["blue"]], linewidths=1.4)
    ax.contour(x, y, vs, levels=[supervisor.mu], colors=[PALETTE["vermillion"]], linewidths=1.0, linestyles="--")
    ax.add_patch(Circle((0, 0), fit.value_fn.obstacle_radius, color=PALETTE["black"]))
    ax.scatter(canon[:, 0], canon[:, 1], s=12, facecolors="none", edgecolors=PALETTE["vermillion"])
    ax.plot([], [], color=PALETTE["blue"], label=f"fitted: w={fit.w_max:g}, level mu+{k:g}sigma")
    ax.plot([], [], color=PALETTE["vermillion"], ls="--", label=f"supervisor's own: w={supervisor.value_fn.w_max:g}, mu")
    ax.set(xlim=(-6, 3), ylim=(-4, 4), aspect="equal", xlabel="x (obstacle radii)", ylabel="y (obstacle radii)")
    ax.legend(fontsize=5.5, loc="lower right")


def sample_efficiency_figure(summary):
    """`fig_ext_cycle_learn`: precision and recall, the training log-likelihood gap to the truth and the held-out
    demonstrations the inferred constraints allow, against N (means over seeds, 95% bootstrap CIs)."""
    fig = Figure(figsize=(10, 3.6), layout="constrained")
    axes = fig.subplots(1, 3)
    n = summary["n_demos"]
    for ax, cols in zip(axes, (("precision", "recall_relevant", "recall_all"), ("loglik_gap",), ("heldout_allowed",))):
        for col in cols:
            ax.errorbar(n, summary[col], yerr=[summary[col] - summary[f"{col}_low"], summary[f"{col}_high"] - summary[col]],
                        marker="o", capsize=3, label=col.replace("_", " "))
        ax.set_xscale("log")
        ax.set_xticks(n, [str(v) for v in n])
        ax.minorticks_off()
        ax.set_xlabel("demonstrations N")
    axes[0].set(ylabel="share", ylim=(0, 1.05), title="inferred constraints vs truth")
    axes[0].legend(fontsize=7)
    axes[1].axhline(0, color="0.7", lw=0.8)
    axes[1].set(ylabel="nats per demonstration", title="log-likelihood: inferred - true constraints")
    axes[2].set(ylabel="share", ylim=(0, 1.05), title="fresh demonstrations the inferred\nconstraints allow")
    fig.suptitle(f"Sample efficiency (simulated; means over {int(summary['n'].iloc[0])} seeds, 95% bootstrap CIs)",
                 fontsize=10)
    return fig


def act_figure(robots, blind):
    """`fig_ext_cycle_act`: exact outcomes of each robot in task 2, and recall of task 2's constraints when
    inferring from task 1 alone or pooled with task 2 (means over seeds, 95% bootstrap CIs)."""
    fig = Figure(figsize=(9, 3.2), layout="constrained")
    ax, bx = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.5, 1]})
    x = np.arange(len(robots))
    for i, (col, label) in enumerate((("p_break", "breaks a true constraint"), ("p_enter", "enters a true cell"))):
        ax.bar(x + (i - 0.5) * 0.38, robots[col], width=0.38, label=label)
    ax.set_xticks(x, robots["robot"], fontsize=8)
    ax.set(ylabel="probability (exact)", ylim=(0, 1), title="Act in task 2 (simulated world)")
    ax.legend(fontsize=7)
    bx.bar(np.arange(len(blind)), blind["recall_relevant"], color=PALETTE["green"],
           yerr=[blind["recall_relevant"] - blind["recall_relevant_low"], blind["recall_relevant_high"] - blind["recall_relevant"]],
           capsize=3)
    bx.set_xticks(np.arange(len(blind)), blind["demonstrations"], fontsize=8)
    bx.set(ylabel="recall of task 2's relevant constraints", ylim=(0, 1.05),
           title="The blind spot of Fig. 3.3\n(95% bootstrap CI over seeds)")
    fig.suptitle("Acting on learned constraints (simulated human and world)", fontsize=10)
    return fig


def observer_figure(curves, horizon, level, sweep):
    """`fig_ext_cycle_show`: the observer's mean posterior over repeated episodes, the share of observers confident
    by each step, and the exact trade-off of legibility against reward over alpha."""
    fig = Figure(figsize=(10.5, 3.4), layout="constrained")
    axes = fig.subplots(1, 3)
    for name, cur in curves.items():
        t = np.arange(len(cur["mean_posterior"]))
        axes[0].plot(t, cur["mean_posterior"], color=ROBOT_COLOURS.get(name), label=f"{name} robot")
        times = np.where(np.isnan(cur["time"]), np.inf, cur["time"])
        axes[1].step(t, [(times <= s).mean() for s in t], where="post", color=ROBOT_COLOURS.get(name), label=f"{name} robot")
    for ax in axes[:2]:
        for k in range(1, len(curves[next(iter(curves))]["mean_posterior"]) // horizon + 1):
            ax.axvline(k * horizon, color="0.8", lw=0.8)
        ax.set_xlabel("steps watched (episodes of T steps)")
        ax.legend(fontsize=7)
    axes[0].axhline(level, color=PALETTE["vermillion"], ls="--", lw=0.8)
    axes[0].set(ylabel="mean P(H1 | seen so far)", title="observer's belief (simulated rollouts)")
    axes[1].set(ylabel=f"share with P(H1) >= {level:g}", ylim=(0, 1.02), title="time to confidence")
    finite = sweep[np.isfinite(sweep["alpha"])]
    axes[2].plot(finite["expected_reward"], finite["mean_log_odds_over_time"], marker="o", color=PALETTE["green"])
    for _, r in finite.iterrows():
        axes[2].annotate(f"alpha={r['alpha']:g}", (r["expected_reward"], r["mean_log_odds_over_time"]), fontsize=6)
    plain = sweep[np.isinf(sweep["alpha"])].iloc[0]
    axes[2].plot(plain["expected_reward"], plain["mean_log_odds_over_time"], "s", color=ROBOT_COLOURS["plain"], label="plain")
    axes[2].set(xlabel="expected task reward (exact)", ylabel="mean expected log-odds over time",
                title="legibility vs reward (exact)")
    axes[2].legend(fontsize=7)
    fig.suptitle("Showing the constraints to the human observer (simulated)", fontsize=10)
    return fig


def evidence_figure(paths, posteriors, dt, crossing, radius, level_sets, title="Evident safety for the supervisor (simulated)"):
    """`fig_ext_cycle_evident_first`: the iLQR paths of H0, H1 and the legible robot around the obstacle with the boundaries of
    the unsafe sets ``{label: (w_max, level)}`` for a car heading east (+x), and the supervisor's posterior
    (the moment an ignorant robot reaches the supervisor's level, ``crossing``, is drawn when finite)."""
    fig = Figure(figsize=(9.5, 3.4), layout="constrained")
    ax, bx = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.6, 1]})
    for name, r in paths.items():
        ax.plot(r.xs[:, 0], r.xs[:, 1], color=ROBOT_COLOURS.get(name), label=name)
    ax.add_patch(Circle((0, 0), radius, color=PALETTE["black"], alpha=0.8))
    gx, gy = np.meshgrid(np.linspace(-8, 8, 241), np.linspace(-4, 4, 121))
    heading0 = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
    for (label, (w_max, level)), style in zip(level_sets.items(), ("-", "--")):
        v = avoid_value_closed_form(heading0, w_max, radius).reshape(gx.shape)
        ax.contour(gx, gy, v, levels=[level], colors=[PALETTE["vermillion"]], linewidths=0.8, linestyles=style)
        ax.plot([], [], color=PALETTE["vermillion"], lw=0.8, ls=style, label=label)
    ax.set(aspect="equal", xlabel="x (obstacle radii)", ylabel="y (obstacle radii)", title="iLQR paths (simulated task)")
    ax.legend(fontsize=6, loc="upper left")
    for name, post in posteriors.items():
        bx.plot(dt * np.arange(len(post)), post, color=ROBOT_COLOURS.get(name), label=f"{name} robot")
    bx.axhline(0.95, color=PALETTE["vermillion"], ls="--", lw=0.8)
    if np.isfinite(crossing):
        bx.axvline(crossing, color=PALETTE["black"], ls=":", lw=0.8, label="ignorant robot reaches\nthe supervisor's level")
    bx.set(xlabel="time (s)", ylabel="P(H1 | motion so far)", title="supervisor's posterior")
    bx.legend(fontsize=6)
    fig.suptitle(title, fontsize=10)
    return fig


def supervision_figure(interventions, fit, supervisor, fp, refits):
    """`fig_ext_cycle_supervision`: the supervisor's interventions and fitted safe set; false-positive probabilities of
    each controller (95% bootstrap CI over robots) and of the learned robot refitted per seed."""
    fig = Figure(figsize=(10.5, 3.4), layout="constrained")
    ax, bx, cx = fig.subplots(1, 3, gridspec_kw={"width_ratios": [1.2, 1, 1]})
    _supervisor_panel(ax, interventions, fit, supervisor)
    ax.set_title("interventions (simulated) and fitted set", fontsize=9)
    bx.bar(np.arange(len(fp)), fp["p_false_positive"], color=PALETTE["sky"],
           yerr=[fp["p_false_positive"] - fp["low"], fp["high"] - fp["p_false_positive"]], capsize=3)
    bx.plot(np.arange(len(fp)), fp["sampled"], "k_", ms=14, label="one sampled judgement per robot")
    bx.set_xticks(np.arange(len(fp)), fp["controller"])
    bx.set(ylabel="P(false-positive intervention)", ylim=(0, 1.25), yticks=np.linspace(0, 1, 6),
           title="main fit (95% bootstrap CI)")
    bx.legend(fontsize=6.5, loc="upper left")
    for recovered, colour in ((True, PALETTE["green"]), (False, PALETTE["vermillion"])):
        part = refits[refits["recovered"] == recovered]
        cx.plot(part["seed"], part["p_false_positive"], "o", color=colour,
                label=("w_max recovered" if recovered else "another w_max chosen") + f" ({len(part)})")
    cx.set(xlabel="refit seed", ylabel="P(false positive), learned robot", ylim=(-0.02, 1.05),
           title=f"refits from {fit.n} fresh interventions")
    cx.legend(fontsize=6.5)
    fig.suptitle("Learning the supervisor and acting on the fit (simulated supervisor)", fontsize=10)
    return fig
