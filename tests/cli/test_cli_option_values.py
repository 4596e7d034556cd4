"""Option values users write that start with '-' (a negative number, a list of them): every parser of
every ``mutual`` command reads them as values, says how to pass any other such value, and a refused
bound is shown with every digit (``-0.5000001``, never the ``-0.5`` it violates)."""

import argparse
import json

import pytest

from mutual.cli import build_parser, common, main

EXAMPLES = __import__("pathlib").Path(__file__).resolve().parents[2] / "data" / "examples"


def _parsers(parser):
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from _parsers(sub)


def _valued_options(parser):
    return [a for a in parser._actions if a.option_strings and a.nargs != 0 and not isinstance(
        a, (argparse._HelpAction, argparse._VersionAction, argparse._SubParsersAction))]


PARSERS = list(_parsers(build_parser()))


@pytest.mark.parametrize("parser", PARSERS, ids=[p.prog for p in PARSERS])
@pytest.mark.parametrize("value", ["-1", "-0.5", "-1e-3", "-.5", "-1,1", "-0.5,-0.25,0", "-inf"])
def test_every_option_takes_a_value_that_starts_with_a_minus(parser, value):
    """Each option that takes a value, alone on a throwaway copy of its parser, gets the value as written."""
    assert isinstance(parser, common.Parser)
    for action in _valued_options(parser):
        probe = common.Parser(prog="probe", add_help=False)
        kwargs = {"nargs": action.nargs} if action.nargs not in (None, "?") else {}
        probe.add_argument(action.option_strings[0], dest="x", **kwargs)
        parsed = probe.parse_args([action.option_strings[0], value] + ([value] * (action.nargs - 1)
                                                                     if isinstance(action.nargs, int) else []))
        assert parsed.x in (value, [value] * (action.nargs if isinstance(action.nargs, int) else 1)), action


def test_a_value_that_is_not_a_number_gets_the_equals_form(tmp_path, capsys):
    path = tmp_path / "i.csv"
    path.write_text((EXAMPLES / "interventions.csv").read_text())
    with pytest.raises(SystemExit) as exit_:
        main(["supervisor", "fit", str(path), "--participant", "-sim"])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "argument --participant: expected one argument (a value that starts with '-' " \
                                      "is written --participant=VALUE)" in err
    status = main(["supervisor", "fit", str(path), "--participant=-sim", "--no-progress", "--out", str(tmp_path / "o")])
    assert status == 2 and "no intervention of participant '-sim'" in capsys.readouterr().err


def test_a_negative_list_reaches_the_check_that_refuses_it(tmp_path, capsys):
    path = tmp_path / "i.csv"
    path.write_text((EXAMPLES / "interventions.csv").read_text())
    status = main(["supervisor", "fit", str(path), "--w-max", "-1,1", "--no-progress", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert status == 2 and "expected one argument" not in err and "w_max" in err, err


@pytest.mark.parametrize("argv, phrase", [
    (["--f", "0.25", "--m", "3", "--rho", "-0.5000001"], "--rho -0.5000001: below -1/(m-1) = -0.5 for --m 3"),
    (["--f", "0.25", "--m", "5", "--rho", "-0.2500000001"], "--rho -0.2500000001: below -1/(m-1) = -0.25 for --m 5"),
    (["--f", "0.25", "--m", "4", "--rho", "-0.33333334"], "--rho -0.33333334: below -1/(m-1) = -0.3333333333333333"),
    (["--f", "0.25", "--rho", "-1.0000001"], "--rho must be a number in [-1, 1), got -1.0000001"),
    (["--f", "0.25", "--m", "3", "--eps", "0.49999999"], "--eps 0.49999999: epsilon lies in [1/(m-1), 1] = [0.5, 1]"),
    (["--f", "0.25", "--alpha", "0.05", "--power", "0.04999999"], "--power 0.04999999: a target power must exceed "
                                                                  "--alpha 0.05"),
])
def test_a_refused_bound_is_shown_with_every_digit(argv, phrase, capsys):
    try:
        status = main(["study", "power", *argv, "--no-progress"])
    except SystemExit as exit_:
        status = exit_.code
    assert status == 2 and phrase in capsys.readouterr().err


def test_a_negative_correlation_within_the_bound_is_accepted(tmp_path, capsys):
    status = main(["study", "power", "--f", "0.25", "--m", "3", "--rho", "-0.5", "--json", "--no-progress",
                   "--out", str(tmp_path)])
    assert status == 0 and json.loads(capsys.readouterr().out)["gpower"]["rho"] == -0.5
