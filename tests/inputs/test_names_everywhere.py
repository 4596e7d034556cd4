"""One rule for names that differ only by surrounding spaces, in every reader of names: the study's
tables, the interventions, the continuous recordings and ``mutual study anova`` all refuse ``'sim-01'``
beside ``' sim-01'`` (or ``'demo-004 '`` beside ``'demo-004'``), naming both spellings and their lines."""

import pytest

from mutual.cli import main
from mutual.constraints.continuous import read_recording
from mutual.study import read_table
from mutual.supervision import read_interventions

TRIALS = ("participant,comparison,order,treatment,task_version,trial,measure,value\n"
          "{a},S-L,1,S,1,1,trips,3\n{a},S-L,2,L,2,2,trips,4\n{b},S-L,1,S,1,3,trips,2\n{b},S-L,2,L,2,4,trips,6\n")
LONG = "who,cond,y\n{a},u,1\n{a},v,2\n{b},u,2\n{b},v,4\nx,u,1\nx,v,3\n"
INTERVENTIONS = "participant,trial,time,x,y,theta\n{a},0,1.0,-3,0.5,0.1\n{b},1,1.2,-3,0.5,0.1\n"
TRAJECTORIES = "demo,t,theta,theta_dot\n{a},0,0,0\n{a},0.1,0,0\n{b},0,0,0\n{b},0.1,0,0\n"


def _trials(path):
    return read_table(path, "trials")


def _long(path):
    return read_table(path, "long", dv="y", within="cond", subject="who")


def _interventions(path):
    return read_interventions(path)


def _recording(path):
    return read_recording(path, ("theta", "theta_dot"))


def _anova(path):
    status = main(["study", "anova", str(path), "--dv", "y", "--within", "cond", "--subject", "who",
                   "--out", str(path.parent / "out"), "--no-progress"])
    if status:
        raise ValueError(f"exit status {status}")


READERS = [  # (reader, template, the first line of {a}, the first line of {b})
    (_trials, TRIALS, 2, 4), (_long, LONG, 2, 4), (_interventions, INTERVENTIONS, 2, 3),
    (_recording, TRAJECTORIES, 2, 4), (_anova, LONG, 2, 4),
]
SPELLINGS = [("sim-01", " sim-01"), ("demo-004 ", "demo-004"), ("P1", "P1\t"), ("Zo\u00eb", "Zoe\u0308")]


@pytest.mark.parametrize("reader, template, line_a, line_b", READERS, ids=[r[0].__name__ for r in READERS])
@pytest.mark.parametrize("a, b", SPELLINGS, ids=["leading", "trailing", "tab", "unicode"])
def test_every_reader_refuses_names_that_differ_only_by_spaces(reader, template, line_a, line_b, a, b, tmp_path,
                                                               capsys):
    path = tmp_path / "t.csv"
    path.write_text(template.format(a=a, b=b))
    with pytest.raises(ValueError) as err:
        reader(path)
    message = str(err.value) + capsys.readouterr().err
    assert f"{a!r} (line {line_a})" in message and f"{b!r} (line {line_b})" in message, message
    assert "differ only in spaces or in how a character is encoded" in message


@pytest.mark.parametrize("reader, template, line_a, line_b", READERS, ids=[r[0].__name__ for r in READERS])
def test_distinct_names_as_text_are_kept_apart(reader, template, line_a, line_b, tmp_path):
    path = tmp_path / "t.csv"
    path.write_text(template.format(a="01", b="1"))
    reader(path)                                  # "01" and "1" are two names, not one spelled twice
