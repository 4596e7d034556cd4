"""Recorded continuous trajectories (``recordings``, ``mapping``): malformed CSV, bad timing and states
outside the box are named by file, line and column; angles wrap, unequal durations can be truncated, a
byte-order mark is accepted and demo ids are text."""

import pytest

from mutual.constraints.continuous import read_recording
from mutual.constraints.continuous.mapping import check_recording

from helpers.continuous import pendulum_problem, write


PENDULUM_CSV = "demo,t,theta,theta_dot,torque\n"


def read(path):
    return read_recording(path, ("theta", "theta_dot"), ("torque",))


def test_a_box_that_excludes_the_demonstrations_names_file_line_and_column(tmp_path):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + "a,0,0,0,3\na,0.1,0.1,9.5,3\na,0.2,0.2,2,\n")
    with pytest.raises(ValueError, match=r"t\.csv, line 3, column 'theta_dot': 9\.5 is outside the box \[-8, 8\]"):
        check_recording(pendulum_problem(), read(path))


def test_angles_outside_their_range_wrap_instead(tmp_path):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + "a,0,7.0,0,3\na,0.1,7.1,1,3\n")
    check_recording(pendulum_problem(), read(path))


@pytest.mark.parametrize("rows, phrase", [
    ("a,0,0,0,3\na,0.1,0,0,3\na,0.3,0,0,3\n", r"line 4, column 't': time jumps from 0\.1 to 0\.3 s .*a gap in time"),
    ("a,0,0,0,3\na,0.1,0,0,3\na,0.1,0,0,3\n", r"line 4, column 't': time 0\.1 repeats"),
    ("a,0,0,0,3\na,0.03,0,0,3\na,0.06,0,0,3\n", "does not divide the model's time step dt = 0.1"),
    ("a,0,0,0,3\na,0.1,0,0,3\nb,0,0,0,3\nb,0.1,0,0,3\nb,0.2,0,0,3\n", "spans 2 steps .* must span the same time"),
])
def test_bad_timing_names_the_line(tmp_path, rows, phrase):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + rows)
    with pytest.raises(ValueError, match=phrase):
        check_recording(pendulum_problem(), read(path))


def test_unequal_durations_can_be_truncated(tmp_path):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + "a,0,0,0,3\na,0.1,0,0,3\nb,0,0,0,3\nb,0.1,0,0,3\nb,0.2,0,0,3\n")
    check_recording(pendulum_problem(), read(path), truncate=True)


@pytest.mark.parametrize("text, phrase", [
    ("", "the file is empty"),
    ("demo,t,theta\n", "line 1: missing column 'theta_dot'"),
    (PENDULUM_CSV, "no data rows after the header"),
    (PENDULUM_CSV + "a,0,zero,0,3\na,0.1,0,0,3\n", r"line 2, column 'theta': 'zero' is not a finite number"),
    (PENDULUM_CSV + "a,0,0,nan,3\na,0.1,0,0,3\n", r"line 2, column 'theta_dot'"),
    (PENDULUM_CSV + "a,0,0,0,3\n,0.1,0,0,3\n", "line 3, column 'demo': empty"),
    (PENDULUM_CSV + "a,0,0,0,3\nb,0,0,0,3\nb,0.1,0,0,3\n", "demonstration 'a' has one row"),
    (PENDULUM_CSV + "a,,0,0,3\na,0.1,0,0,3\n", "line 2, column 't': empty"),
])
def test_malformed_csv_names_file_line_and_column(tmp_path, text, phrase):
    path = write(tmp_path, "t.csv", text)
    with pytest.raises(ValueError, match=phrase):
        read(path)


def test_a_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(b"\xef\xbb\xbf" + (PENDULUM_CSV + "a,0,0,0,3\na,0.1,0,0,3\n").encode())
    assert read(path).ids == ("a",)


def test_demo_ids_are_read_as_text(tmp_path):
    path = write(tmp_path, "t.csv", PENDULUM_CSV + "007,0,0,0,3\n007,0.1,0,0,3\n7,0,0,0,3\n7,0.1,0,0,3\n")
    assert read(path).ids == ("007", "7")
