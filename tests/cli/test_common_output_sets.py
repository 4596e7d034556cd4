"""A command's outputs never clobber: one lock per --out (the notebook runner's too), distinct file names for
distinct requests, no output over an input, a link that leads nowhere named, SIGTERM and kill leaving no
staging folder behind, and an --out a failed run created removed again."""

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mutual.cli import common, main

_RANDOM = random.Random(0)
STUDY = "who,cond,y,a b,a-b\n" + "".join(f"s{i},{c},{i + j * 0.5 + (i * j) % 3},{_RANDOM.gauss(j, 1):.4f},"
                                         f"{_RANDOM.gauss(-j, 1):.4f}\n" for i in range(1, 5) for j, c in enumerate("abc"))


def anova(dv="y", out="out", data="data.csv"):
    return ["study", "anova", data, "--dv", dv, "--within", "cond", "--subject", "who", "--out", out]


@pytest.fixture
def here(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("data.csv").write_text(STUDY)
    return tmp_path


HOLDERS = {
    "another command": "from mutual.folder_lock import hold\nwith hold({out!r}, str):\n",
    "the notebook runner": ("from mutual.compendium.lock import output_lock\n"
                            "with output_lock({out!r}, {out!r} + '-info.json', 'quick', ['01.ipynb'], {{}}):\n"),
}


@pytest.mark.parametrize("holder", sorted(HOLDERS))
def test_a_second_run_into_a_held_folder_stops_at_once(here, capsys, holder):
    out = here / "out"
    out.mkdir()
    code = HOLDERS[holder].format(out=str(out)) + "    print('held', flush=True)\n    import time; time.sleep(60)\n"
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        assert main(anova()) == 2
        assert "--out out: another run is writing its outputs there now" in capsys.readouterr().err
        assert list(out.iterdir()) == []
    finally:
        proc.kill()
        proc.wait()
    assert main(anova()) == 0 and len(list(out.iterdir())) == 4


def test_requests_whose_names_clean_to_the_same_text_write_different_files(here, capsys):
    assert main(anova("a b")) == 0 and main(anova("a-b")) == 0
    names = sorted(p.name for p in (here / "out").iterdir())
    assert len(names) == 8 and "anova_a-b.csv" in names, names
    assert [n for n in names if n.startswith("anova_a-b-") and len(n) == len("anova_a-b-12345678.csv")]


def test_every_request_of_a_small_family_gets_its_own_name():
    """Brute force: --dv and --where combinations that join to the same text (score + g=A and score_A, a b
    and a-b, g=b_c and g=b, h=c) all map to different names; names stay readable where every part is plain."""
    from argparse import Namespace
    from mutual.cli.study import _stem
    dvs = ["a", "a_b", "a b", "a-b", "a_b_c", "score", "score_A"]
    wheres = [[], ["g=b"], ["h=b"], ["g=b", "h=c"], ["g=b_c"], ["g=A"], ["g=b c"]]
    stems = {(dv, tuple(w)): _stem(Namespace(dv=dv, where=w)) for dv in dvs for w in wheres}
    assert len(set(stems.values())) == len(stems)
    assert stems[("score_A", ())] == "score_A" and stems[("score", ("g=A",))] == "score+g=A"
    assert stems[("a b", ("g=b c",))].startswith("a-b+g=b-c-")


def test_a_filtered_request_and_a_column_named_like_it_write_different_files(here, capsys):
    Path("data.csv").write_text("who,cond,g,y,y_A\n" + "".join(
        f"s{i},{c},A,{_RANDOM.gauss(j, 1):.4f},{_RANDOM.gauss(-j, 1):.4f}\n" for i in range(1, 5) for j, c in enumerate("abc")))
    assert main(anova("y") + ["--where", "g=A"]) == 0 and main(anova("y_A")) == 0
    names = sorted(p.name for p in (here / "out").iterdir())
    assert len(names) == 8 and "anova_y_A.csv" in names, names


def test_an_output_never_replaces_the_runs_input(here, capsys):
    (here / "out").mkdir()
    (here / "out" / "cells_y.csv").write_text(STUDY)
    assert main(anova(data="out/cells_y.csv")) == 2
    err = capsys.readouterr().err
    assert "the output cells_y.csv would replace the input out/cells_y.csv" in err
    assert (here / "out" / "cells_y.csv").read_text() == STUDY
    assert sorted(p.name for p in (here / "out").iterdir()) == ["cells_y.csv"]


@pytest.mark.parametrize("link", ["dangling", "loop"])
def test_an_out_link_that_leads_nowhere_is_named(here, capsys, link):
    os.symlink("nowhere" if link == "dangling" else "out", here / "out")
    assert main(anova()) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out out: a symbolic link that leads to no folder" in err[0]


def test_sigterm_while_writing_leaves_nothing(here, capsys, monkeypatch):
    figure = common.OutputSet.figure

    def terminated_while_drawing(self, fig, name):
        figure(self, fig, name)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)                           # the handler raises at once

    monkeypatch.setattr(common.OutputSet, "figure", terminated_while_drawing)
    before = signal.getsignal(signal.SIGTERM)
    assert main(anova()) == common.EXIT_TERMINATED
    assert "terminated (SIGTERM)" in capsys.readouterr().err
    assert not (here / "out").exists()          # created by this run, left empty: removed
    assert signal.getsignal(signal.SIGTERM) is before          # the command's handler is gone again


def test_a_staging_folder_left_by_a_killed_run_is_removed_by_the_next(here, capsys):
    stale = here / "out" / f"{common.STAGING}killed"
    stale.mkdir(parents=True)
    (stale / "anova_y.csv").write_text("half")
    assert main(anova()) == 0
    assert sorted(p.name for p in (here / "out").iterdir()) == ["anova_y.csv", "cells_y.csv", "means_y.png",
                                                               "pairwise_y.csv"]


def test_a_killed_command_leaves_a_staging_folder_that_the_next_run_clears(here):
    env = {**os.environ, "MUTUAL_TEST_SLOW_FIGURE": "1"}
    code = ("import time, mutual.cli.common as c\n"
            "f = c.OutputSet.figure\n"
            "def slow(self, fig, name):\n    f(self, fig, name); print('writing', flush=True); time.sleep(60)\n"
            "c.OutputSet.figure = slow\n"
            "from mutual.cli import main\n"
            f"main({anova()!r})\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, env=env, cwd=here)
    try:
        assert proc.stdout.readline().strip() == "writing"
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait()
    assert [p.name for p in (here / "out").iterdir() if p.name.startswith(common.STAGING)]
    assert main(anova()) == 0
    assert not [p.name for p in (here / "out").iterdir() if p.name.startswith(".")]
