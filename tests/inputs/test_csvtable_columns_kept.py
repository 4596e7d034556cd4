"""A CSV table read for a few of its columns (``keep``), and a file sized before it is read: the kept columns
equal those of a full read (truth: Python's csv module), a file of 200 000 columns reads without building them,
a missing column's message lists the first columns and counts the rest, and a file beyond the memory or the
time limit is refused with its estimate (``mutual.budget``)."""

import csv

import pytest

from mutual import budget
from mutual.inputs import read_csv, require_columns

PLAIN = "s,c,v,x\nP1,a,1,9\nP1,b,2,8\nP2,a,3,7\nP2,b,4,6\n"
QUOTED = 's,c,v,x\nP1,"a",1,"9\n9"\nP1,b,2,8\n\nP2,a,3,7\nP2,b,"4",6\n'


@pytest.mark.parametrize("text, keep, lines", [
    (PLAIN, {"s", "v"}, [2, 3, 4, 5]),
    (PLAIN, {"v", "s", "absent"}, [2, 3, 4, 5]),
    (QUOTED, {"s", "v"}, [2, 4, 6, 7]),
    (QUOTED, {"x", "c"}, [2, 4, 6, 7]),
    (PLAIN, None, [2, 3, 4, 5]),
])
def test_kept_columns_are_those_of_the_file_in_its_order(tmp_path, text, keep, lines):
    path = tmp_path / "d.csv"
    path.write_text(text, newline="")
    frame = read_csv(path, keep=keep)
    rows = [r for r in csv.reader(text.splitlines(keepends=True)) if r]
    header, body = rows[0], rows[1:]
    expected = [name for name in header if keep is None or name in keep]
    assert list(frame.columns) == expected and list(frame.attrs["header"]) == header
    for name in expected:
        assert frame[name].tolist() == [r[header.index(name)] for r in body]
    assert list(frame.attrs["lines"]) == lines


@pytest.mark.parametrize("text, message", [
    ("s,c,v\nP1,a,1,2\nP1,b,2\n", "d.csv, line 2: the row has 4 fields, the header 3"),
    ("s,c,v\nP1,a\n", "d.csv, line 2: the row has 2 fields, the header 3"),
    ("s,s,v\nP1,a,1\n", "the column name 's' appears twice"),
])
def test_columns_not_kept_are_still_checked(tmp_path, text, message):
    path = tmp_path / "d.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_csv(path, keep={"v"})


def test_a_file_of_200_000_columns_reads_its_kept_columns_and_names_its_width(tmp_path):
    n = 200_000
    path = tmp_path / "wide.csv"
    zeros = ",0" * n
    path.write_text("s,c,v" + "".join(f",x{k}" for k in range(n)) + "\n"
                    + "".join(f"P{i},{c},{i + j}{zeros}\n" for i in range(4) for j, c in enumerate("ab")))
    frame = read_csv(path, keep={"s", "c", "v"})
    assert frame.shape == (8, 3) and frame["v"].tolist() == [str(i + j) for i in range(4) for j in range(2)]
    with pytest.raises(ValueError, match=r"missing column 'w' \(it has columns \['s', 'c', 'v', 'x0', .*'x16'\] "
                                         r"and 199,983 more; expected w\)"):
        require_columns(frame, ["w"])


@pytest.mark.parametrize("free, minutes, phrases", [
    (100, None, ["reading d.csv", "MiB of memory", "are available", "keep only the columns and rows needed"]),
    (1e15, 1e-9, ["reading d.csv", "3 columns", "the limit is 1e-09 minutes", "allow_large=True"]),
])
def test_a_file_beyond_the_budget_is_refused_before_it_is_read(tmp_path, monkeypatch, free, minutes, phrases):
    path = tmp_path / "d.csv"
    path.write_text(PLAIN)
    monkeypatch.setattr(budget, "available_bytes", lambda: free)
    with budget.limits(minutes=minutes), pytest.raises(budget.TooLarge) as err:
        read_csv(path, keep={"s", "c", "v"})
    for phrase in phrases:
        assert phrase in str(err.value)
    with budget.limits(minutes=minutes, allow_large=True):
        assert read_csv(path).shape == (4, 4)
