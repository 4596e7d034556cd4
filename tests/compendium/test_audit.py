"""The checker of an honest report (``mutual.compendium.audit``) on synthetic notebooks: it tells literals from
computed values, resolves what the notebook calls, sees echoes of settings, and refuses claims it cannot read."""

import textwrap

import nbformat
import pytest

from mutual.compendium.audit import NotebookCode, Unresolved


SYNTHETIC = [
    "quick = False\nn_recruits = 12\nw_max = 0.75",
    textwrap.dedent("""\
        import numpy as np
        from mutual.study import stats as st
        from mutual.study.stats import rm_anova
        import mutual.study.data
        const = 3
        derived = const * 2
        table = {}
        for k in range(3):
            table[k] = st.rm_anova(k)
        counts = []
        counts.append(rm_anova(1))
        fixed = []
        fixed.append(1)
        settings = {"goal": [2, -2]}
        total = 0
        total += 1
        summed = 0
        for k in st.rm_anova(3):
            summed += k
        looped = 0
        for j in range(3):
            looped += j
        pairs = [(name, st.rm_anova(name)) for name in ("a", "b")]
        data = mutual.study.data.read_table("x")
        claims = {
            "lit-true": {"value": True, "computed_by": "mutual.study.stats.rm_anova", "note": "n"},
            "lit-arith": {"value": 220 / 397},
            "lit-parameter": {"value": n_recruits},
            "lit-derived": {"value": derived},
            "lit-numpy": {"value": float(np.mean([1.0, 2.0]))},
            "lit-ifexp": {"value": 12 if quick else n_recruits},
            "lit-container": {"value": bool(len(fixed) == 1)},
            "lit-settings": {"value": settings["goal"][0] == 2},
            "lit-augmented": {"value": total},
            "lit-looped": {"value": looped},
            "computed-library": {"value": st.design_from_f_dofs(2, 20)},
            "computed-mutated": {"value": table[0] > 1},
            "computed-appended": {"value": counts[0]},
            "computed-loop": {"value": summed},
            "computed-bare": data,
        }
        proposed = {"computed-filtered": {"value": table[1]}, "unused": {"value": 1}}
        extra = {}
        extra["computed-item"] = {"value": st.rm_anova(2)}
        write_results("09_demo", {**claims, **{k: v for k, v in proposed.items() if k != "unused"}, **extra,
                                  **{f"computed-{name}": {"value": value} for name, value in pairs},
                                  **{f"lit-{kind}": {"value": typed} for kind, typed in [("x", 1.0), ("y", 2.0)]}})"""),
]


@pytest.fixture
def synthetic(tmp_path):
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(s) for s in SYNTHETIC]
    nb.cells[0].metadata["tags"] = ["parameters"]
    path = tmp_path / "09_demo.ipynb"
    nbformat.write(nb, path)
    return NotebookCode(path)


def test_the_checker_tells_literals_from_computed_values(synthetic):
    reported = {r.claim: r for r in synthetic.reported()}
    assert synthetic.parameters == {"quick", "n_recruits", "w_max"}
    literal = {c for c, r in reported.items() if synthetic.is_literal(r.value)}
    assert literal == {c for c in reported if c.startswith(("lit-", "f'lit-")) or c == "unused"}
    assert {c for c, r in reported.items() if r.generated} == {"f'computed-{name}'", "f'lit-{kind}'"}
    assert {"computed-filtered", "computed-item", "computed-bare"} <= set(reported)
    assert reported["lit-true"].computed_by is not None and reported["lit-arith"].computed_by is None
    assert synthetic.scalar_constants() == {"n_recruits": 12, "w_max": 0.75, "const": 3}


def test_the_checker_resolves_what_the_notebook_calls(synthetic):
    from mutual.study import data, stats

    assert synthetic.references(stats.rm_anova)  # through `st.` and through the `from` import
    assert synthetic.references(stats.design_from_f_dofs)
    assert synthetic.references(data.read_table)  # through the full dotted import
    assert not synthetic.references(stats.likert_vs_neutral)


ECHOES = [
    "quick = False\nexample_w_max = 0.75\nexample_mu = 0.5\nn_robots = 400",
    textwrap.dedent("""\
        from mutual.study import stats as st
        sup = st.rm_anova(example_w_max, example_mu)
        fit = st.rm_anova(sup, n_robots)
        recovered = fit.w_max == example_w_max
        close = abs(fit.mu - example_mu) < 0.05
        rate = st.rm_anova(sup)
        honest = rate <= 0.01
        write_results("09_demo", {
            "bool-echo": {"value": recovered}, "bool-close-echo": {"value": bool(close)},
            "bool-np-echo": {"value": bool(st.np.isclose(fit.mu, example_mu))},
            "bool-honest": {"value": honest}, "near-echo": {"value": fit.mu}, "far": {"value": rate},
            "unrelated": {"value": st.rm_anova(3)}})"""),
]


@pytest.mark.parametrize("claim, value, thesis, rule, echo", [
    ("bool-echo", True, "true", "true", True), ("bool-close-echo", True, "true", "true", True),
    ("bool-np-echo", False, "true", "true", True), ("bool-honest", True, "true", "true", False),
    ("near-echo", 0.503, "0.5", "abs:0.05", True), ("near-echo", 0.6, "0.5", "abs:0.05", False),
    ("near-echo", 0.5, "0.5", ">=", True), ("far", 0.56, "0.5", "abs:0.05", False), ("far", 0.53, "0.5", "abs:0.05", True),
    ("unrelated", 0.4975, "0.5", "abs:0.075", False), ("unrelated", 0.5, "0.5", "abs:0.075", True),
    ("near-echo", 0.75, "0.29", "abs:0.05", False),
])
def test_the_checker_sees_echoes(tmp_path, claim, value, thesis, rule, echo):
    """Booleans comparing a result with the setting that made it, and values that only nearly equal a
    typed constant that fed them, are echoes; a value that merely sits near the thesis value is not."""
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(s) for s in ECHOES]
    nb.cells[0].metadata["tags"] = ["parameters"]
    nbformat.write(nb, tmp_path / "09_demo.ipynb")
    code = NotebookCode(tmp_path / "09_demo.ipynb")
    reported = {r.claim: r for r in code.reported()}
    assert bool(code.echo(reported[claim], thesis, rule, value)) is echo


def test_the_checker_refuses_claims_it_cannot_read(tmp_path):
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell("quick = False"), nbformat.v4.new_code_cell(
        "claims = make_claims()\nwrite_results('09_demo', claims)")]
    nbformat.write(nb, tmp_path / "09_demo.ipynb")
    with pytest.raises(Unresolved, match=r"code cell 2: cannot read the claims from 'make_claims\(\)'"):
        NotebookCode(tmp_path / "09_demo.ipynb").reported()
