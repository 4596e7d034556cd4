"""Make ``pingouin_rm_anova.json``: pingouin's one-way ``rm_anova`` on the data sets below, the
reference that ``tests/cli/test_study.py`` checks ``mutual study anova`` against.

pingouin is not in the compendium's lock (it would add scikit-learn, xarray and seaborn, about 82 MB,
for one test; ``make bench-peers`` has it), so its values were computed once in a scratch venv and
committed with this script::

    python3.11 -m venv /tmp/pg && /tmp/pg/bin/pip install pingouin==0.7.0
    /tmp/pg/bin/python tests/data/pingouin_rm_anova.py      # rewrites tests/data/pingouin_rm_anova.json

Every data set is a long table whose subject and level names are text, read by pandas with
``dtype=str`` (so ``01`` and ``1`` stay two people, ``NA`` and ``None`` stay names).
"""

import io
import json
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent


def _long(subjects, levels, values):
    rows = [f"{s},{lvl},{values[i][j]!r}" for i, s in enumerate(subjects) for j, lvl in enumerate(levels)]
    return "subject,level,y\n" + "\n".join(rows) + "\n"


def datasets():
    """name -> CSV text (subject, level, y); the generator's seeds are fixed."""
    rng = np.random.default_rng(2024)
    out = {
        # 01 and 1 are two people
        "ids_01_and_1": "subject,level,y\n01,a,1\n01,b,3\n1,a,2\n1,b,5\n2,a,4\n2,b,5\n",
        "levels_like_numbers": _long(["s1", "s2", "s3", "s4", "s5"], ["1", "1.0", "01"],
                                     rng.normal(10, 2, (5, 3)).round(3).tolist()),
        "levels_na_none": _long(["a", "b", "c", "d"], ["NA", "None", "nan", "N/A"],
                                (rng.normal(0, 1, (4, 4)) + [0, 0.5, 1, 1.5]).round(4).tolist()),
        "ids_like_missing": _long(["NA", "None", "null", "#N/A", "TRUE", "0"], ["u", "v"],
                                  rng.normal(5, 1, (6, 2)).round(2).tolist()),
        "random_k4_n9": _long([f"p{i}" for i in range(9)], ["A", "B", "C", "D"],
                              (rng.normal(0, 1, (9, 4)) + rng.normal(0, 1, (9, 1)) + [0, 0.3, 0.6, 0.2]).tolist()),
    }
    return out


def reference(csv_text):
    import pingouin as pg
    data = pd.read_csv(io.StringIO(csv_text), dtype={"subject": str, "level": str}, keep_default_na=False)
    detailed = pg.rm_anova(data, dv="y", within="level", subject="subject", detailed=True, correction=True,
                           effsize="np2")
    ng2 = pg.rm_anova(data, dv="y", within="level", subject="subject", correction=True, effsize="ng2")
    effect, error = detailed.iloc[0], detailed.iloc[1]
    return {"SS_effect": float(effect["SS"]), "SS_error": float(error["SS"]), "df1": int(effect["DF"]),
            "df2": int(error["DF"]), "MS_effect": float(effect["MS"]), "MS_error": float(error["MS"]),
            "F": float(effect["F"]), "p": float(effect["p_unc"]), "eps": float(ng2["eps"].iloc[0]),
            "p_gg": float(ng2["p_GG_corr"].iloc[0] if "p_GG_corr" in ng2 else ng2["p_unc"].iloc[0]),  # k = 2: eps = 1
            "eta2p": float(effect["np2"]), "eta2g": float(ng2["ng2"].iloc[0]),
            "n_subjects": int(data["subject"].nunique())}


def main():
    import pingouin
    cases = {name: {"csv": text, "pingouin": reference(text)} for name, text in datasets().items()}
    payload = {"made_by": f"tests/data/pingouin_rm_anova.py with pingouin {pingouin.__version__}", "cases": cases}
    (HERE / "pingouin_rm_anova.json").write_text(json.dumps(payload, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
