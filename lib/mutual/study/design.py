"""The within-subjects design of the chapter 5 user study (section 5.2.4).

Every participant completes all three pairwise comparisons of the three safe
sets (Standard, Learned, Conservative), each comparison being two trials, one
per team. The order of the comparisons follows a balanced Latin square
(Williams design), and within a participant no treatment is first in a pair
twice: the three pairs are oriented cyclically (S>L, L>C, C>S or its reverse).
Six task versions are used, a different one for each of a participant's six
trials, and across every block of twelve participants each treatment is paired
with each task version equally often (four times).
"""

import numpy as np
import pandas as pd

TREATMENTS = ("Standard", "Learned", "Conservative")
OBSTACLE_RADIUS = 1.0     # the teaming task's obstacles (positions are in these units; Sec. 5.2.2)
N_VERSIONS = 6
DESIGN_COLUMNS = ["participant", "trial", "comparison", "order", "treatment", "task_version"]


def _check_treatments(treatments):
    names = tuple(treatments) if isinstance(treatments, (list, tuple)) else None
    if names is None or len(names) != 3 or not all(isinstance(t, str) and t.strip() for t in names):
        raise ValueError(f"treatments must be three names (non-empty strings), got {treatments!r}")
    if len(set(names)) != 3:
        raise ValueError(f"treatments must be three different names, got {treatments!r}")
    return names


def comparison_label(a, b, treatments=TREATMENTS):
    """Canonical name of the pair {a, b}: the two treatments in ``treatments`` order, joined by '-'."""
    treatments = _check_treatments(treatments)
    for t in (a, b):
        if t not in treatments:
            raise ValueError(f"treatment {t!r} is not one of {treatments}")
    if a == b:
        raise ValueError(f"a comparison needs two different treatments, got {a!r} twice")
    i, j = sorted((treatments.index(a), treatments.index(b)))
    return f"{treatments[i]}-{treatments[j]}"


def balanced_latin_square(n):
    """Williams' balanced Latin square for ``n`` conditions.

    Rows are orderings; every condition appears once per position and
    immediately follows every other condition equally often. For odd ``n`` the
    square is stacked with its mirror image (2n rows), as balance requires.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    k = np.arange(1, n)
    first = np.concatenate([[0], np.where(k % 2 == 1, (k + 1) // 2, n - k // 2) % n])  # 0, 1, n-1, 2, n-2, ...
    square = (first[None, :] + np.arange(n)[:, None]) % n
    return square if n % 2 == 0 else np.vstack([square, square[:, ::-1]])


def _pair_orientations(treatments=TREATMENTS):
    """The two cyclic orientations of the three pairs: no treatment first twice."""
    s, l, c = treatments
    return ([(s, l), (l, c), (c, s)], [(l, s), (c, l), (s, c)])


def study_design(n_participants=12, seed=0, treatments=TREATMENTS):
    """Trial schedule as a tidy table with columns ``DESIGN_COLUMNS``.

    ``treatments``: the three conditions' names (the thesis's safe sets by default).

    Participant ``p`` (0-based) gets comparison order ``p % 6`` of the balanced
    Latin square over the three pairs and pair orientation ``(p // 6) % 2``, so
    twelve participants cover all twelve schedules once. Task versions: the six
    versions are split into three blocks of two (after a seeded random
    relabelling); treatment ``i`` gets block ``(i + p) % 3`` and the two trials
    of a treatment take the block's versions in an order that alternates with
    ``p // 3``. Participants and versions are numbered from 1.
    """
    if isinstance(n_participants, bool) or not isinstance(n_participants, (int, np.integer)) or n_participants < 1:
        raise ValueError(f"n_participants must be a positive integer, got {n_participants!r}")
    treatments = _check_treatments(treatments)
    rng = np.random.default_rng(seed)
    versions = rng.permutation(N_VERSIONS) + 1
    blocks = versions.reshape(3, 2)
    square = balanced_latin_square(3)
    rows = []
    for p in range(n_participants):
        pairs = _pair_orientations(treatments)[(p // 6) % 2]
        seen = dict.fromkeys(treatments, 0)
        trial = 0
        for position in square[p % len(square)]:
            a, b = pairs[position]
            for order, treatment in enumerate((a, b), start=1):
                i = treatments.index(treatment)
                block = blocks[(i + p) % 3]
                version = block[(seen[treatment] + p // 3) % 2]
                seen[treatment] += 1
                trial += 1
                rows.append((p + 1, trial, comparison_label(a, b, treatments), order, treatment, int(version)))
    return pd.DataFrame(rows, columns=DESIGN_COLUMNS)


def design_balance(design, treatments=TREATMENTS):
    """Balance checks of a schedule from :func:`study_design` (or a real one) of ``treatments``.

    Returns a dict: ``all_pairs`` (every participant did each comparison once),
    ``no_treatment_first_twice``, ``distinct_versions`` (a new task version on
    every trial), ``version_counts`` (treatment x task version count table) and
    ``position_counts`` (comparison x position-in-sequence count table).
    """
    if not isinstance(design, pd.DataFrame):
        raise ValueError(f"design must be a pandas DataFrame, got {type(design).__name__}")
    missing = [c for c in DESIGN_COLUMNS if c not in design.columns]
    if missing:
        raise ValueError(f"design is missing columns {missing}")
    treatments = _check_treatments(treatments)
    unknown = sorted(set(design["treatment"]) - set(treatments))
    if unknown:
        raise ValueError(f"design has treatment(s) {unknown} not among {treatments}")
    d = design.drop_duplicates(["participant", "trial"])
    per = d.groupby("participant")
    all_pairs = per["comparison"].apply(lambda s: sorted(s.unique()) == sorted(
        {comparison_label(a, b, treatments) for a, b in _pair_orientations(treatments)[0]}) and len(s) == 6).all()
    firsts = d[d["order"] == 1].groupby(["participant", "treatment"]).size()
    no_first_twice = bool((firsts <= 1).all())
    distinct_versions = bool(per["task_version"].nunique().eq(per.size()).all())
    version_counts = pd.crosstab(d["treatment"], d["task_version"]).reindex(list(treatments))
    seq = d[d["order"] == 1].sort_values(["participant", "trial"]).copy()
    seq["position"] = seq.groupby("participant").cumcount() + 1
    position_counts = pd.crosstab(seq["comparison"], seq["position"])
    return {"all_pairs": bool(all_pairs), "no_treatment_first_twice": no_first_twice,
            "distinct_versions": distinct_versions, "version_counts": version_counts,
            "position_counts": position_counts}
