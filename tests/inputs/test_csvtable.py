"""The one CSV reader (mutual.inputs.read_csv): the same cells as pandas on well-formed files, and the
file's own line -- found independently, by searching the raw text -- in every error about a bad file."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mutual.inputs import format_exact, name_column, number_column, place, read_csv

ROOT = Path(__file__).resolve().parents[2]
COMMITTED = sorted((ROOT / "data").rglob("*.csv"))


@pytest.mark.parametrize("path", COMMITTED, ids=lambda p: str(p.relative_to(ROOT)))
def test_well_formed_files_read_as_pandas_reads_them(path):
    """pandas (text cells, only empty cells missing) is the independent truth on every committed table."""
    truth = pd.read_csv(path, dtype=str, keep_default_na=False, na_values=[""], encoding="utf-8-sig")
    pd.testing.assert_frame_equal(read_csv(path), truth)


def test_random_tables_read_as_pandas_reads_them(tmp_path):
    rng = np.random.default_rng(3)
    words = ["01", "1", "NA", "None", "nan", " x", "a,b", 'say "hi"', "", "-0", "1e3", "é"]
    cells = rng.choice(words, size=(40, 5))
    path = tmp_path / "t.csv"
    pd.DataFrame(cells, columns=list("abcde")).to_csv(path, index=False)
    truth = pd.read_csv(path, dtype=str, keep_default_na=False, na_values=[""])
    pd.testing.assert_frame_equal(read_csv(path), truth)


def _line_of_marker(text):
    """The 1-based line of the raw text that holds the marker BAD (the truth the reader must name)."""
    return next(i for i, line in enumerate(text.splitlines(), start=1) if "BAD" in line)


LINES = [  # (case, CSV text with the bad cell BAD in column 'y')
    ("plain", "id,y\na,1\nb,BAD\n"),
    ("blank lines before", "id,y\n\n\na,1\n\nb,BAD\n"),
    ("a quoted line break before", 'id,y\n"a\nstill a",1\nb,BAD\n'),
    ("two quoted line breaks in the row itself", 'id,y\n"a\n\nb",BAD\n'),
    ("CRLF and blank lines", "id,y\r\n\r\na,1\r\n\r\nb,BAD\r\n"),
    ("a quoted line break and blank lines", 'id,note,y\n"a","x\ny",1\n\n\n"b","z",BAD\n'),
    ("whitespace-only lines", "id,y\n  \na,1\n \t\nb,BAD\n"),
]


@pytest.mark.parametrize("case, text", LINES, ids=[c[0] for c in LINES])
def test_errors_name_the_files_own_line(case, text, tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(text.encode())
    frame = read_csv(path)
    with pytest.raises(ValueError) as err:
        number_column(frame, "y")
    assert str(err.value).startswith(f"{path}, line {_line_of_marker(text)}, column 'y': 'BAD'"), err.value


@pytest.mark.parametrize("text, starts", [
    ("id,y\na,1\n\n\nb,2\n", [2, 5]),
    ('id,y\n"a\nb",1\n"c",2\n', [2, 4]),
    ('\nid,y\n"a\n\n\nb",1\nc,2\n', [3, 7]),
])
def test_each_row_keeps_the_line_it_starts_on(text, starts, tmp_path):
    path = tmp_path / "t.csv"
    path.write_text(text)
    frame = read_csv(path)
    assert [place(frame, label) for label in frame.index] == [f"{path}, line {n}" for n in starts]


BAD_FILES = [  # (case, CSV text, the phrases of the error, in order)
    ("a comma after every data row", "id,y\na,1,\nb,2,\n",
     ["line 2", "every data row has more fields than the header (3 against 2)", "trailing commas"]),
    ("a comma after one row", "id,y\na,1\nb,2,\n", ["line 3", "3 fields, the header 2", "extra comma"]),
    ("a field too many", "id,y\na,1\nb,2,3\n", ["line 3", "3 fields, the header 2"]),
    ("a field too few", "id,y,z\na,1,2\n\nb,2\n", ["line 4", "2 fields, the header 3"]),
    ("a repeated column", "id,y,y\na,1,2\n", ["line 1", "'y' appears twice", "columns 2 and 3"]),
    ("a repeated column with a space", "id, y,y\na,1,2\n", ["'y' appears twice", "(as ' y')"]),
    ("a column without a name", "id,,y\na,1,2\n", ["line 1", "column 2 of the header has no name"]),
    ("semicolons", "id;y\na;1\n", ["seems to use ';' (semicolon)"]),
    ("tabs", "id\ty\na\t1\n", ["seems to use a tab"]),
    ("a quote never closed", 'id,y\na,"1\nb,2\n', ["line", "not a readable CSV file", "must be quoted"]),
    ("text after a closing quote", 'id,y\n"a"b,1\n', ["line 2", "not a readable CSV file"]),
    ("an empty file", "", ["the file is empty"]),
    ("blank lines only", "\n\n \n", ["the file is empty"]),
    ("a header only", "id,y\n\n", ["no data rows after the header"]),
]


@pytest.mark.parametrize("case, text, phrases", BAD_FILES, ids=[c[0] for c in BAD_FILES])
def test_malformed_files_are_refused_naming_the_line(case, text, phrases, tmp_path):
    path = tmp_path / "t.csv"
    path.write_text(text)
    with pytest.raises(ValueError) as err:
        read_csv(path)
    message = str(err.value)
    assert message.startswith(str(path)) and "\n" not in message
    at = 0
    for phrase in phrases:
        at = message.find(phrase, at)
        assert at >= 0, (phrase, message)


@pytest.mark.parametrize("data, phrase", [
    ("id,y\na,1\n".encode("utf-16"), r"not a text file \(it is not UTF-8"),
    (b"id,y\na,\xff\n", "not UTF-8: byte"),
])
def test_bytes_that_are_not_utf8_name_the_file(data, phrase, tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(data)
    with pytest.raises(ValueError, match=phrase):
        read_csv(path)


@pytest.mark.parametrize("text, expected", [
    ("id,y,\na,1,\nb,2,\n", [["a", "1"], ["b", "2"]]),          # a comma after the header too: an unnamed empty column
    ("\ufeffid,y\r\na,1\r\n", [["a", "1"]]),                      # byte-order mark and CRLF
    (" id , y \na,1\n", [["a", "1"]]),                            # header names without their spaces
])
def test_friendly_variants_read(text, expected, tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(text.encode())
    frame = read_csv(path)
    assert list(frame.columns) == ["id", "y"] and frame.values.tolist() == expected


def test_missing_columns_are_named_with_the_line_of_the_header(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("\n\nid,z\na,1\n")
    with pytest.raises(ValueError, match=r"t\.csv, line 3: missing column 'y' \(the file has columns \['id', 'z'\]"):
        read_csv(path, ("id", "y"))


NAMES = [  # (case, cells of the column, the two spellings named, or None when the names are fine)
    ("a leading space", ["sim-01", " sim-01"], ("'sim-01' (line 2)", "' sim-01' (line 3)")),
    ("a trailing space", ["demo-004 ", "demo-003", "demo-004"], ("'demo-004 ' (line 2)", "'demo-004' (line 4)")),
    ("a tab", ["P1", "P1\t"], ("'P1' (line 2)", "'P1\\t' (line 3)")),
    ("composed and decomposed", ["Zo\u00eb", "Zoe\u0308"], ("line 2", "line 3")),
    ("names as text", ["01", "1", "NA", "None", "nan", "1.0"], None),
    ("one spelling with spaces", [" x ", " x "], None),
]


@pytest.mark.parametrize("case, cells, named", NAMES, ids=[c[0] for c in NAMES])
def test_one_rule_for_names_that_differ_only_by_spaces(case, cells, named, tmp_path):
    path = tmp_path / "t.csv"
    pd.DataFrame({"who": cells, "y": range(len(cells))}).to_csv(path, index=False)
    frame = read_csv(path)
    if named is None:
        assert list(name_column(frame, "who", strip=False)) == cells
        return
    with pytest.raises(ValueError) as err:
        name_column(frame, "who")
    assert all(n in str(err.value) for n in named) and "differ only in spaces" in str(err.value)


def test_numbers_beyond_a_doubles_digits_are_refused_with_that_reason(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("id,y\na,9007199254740993\nb,9007199254740992\nc,3\n")
    frame = read_csv(path)
    assert number_column(frame, "y")[0] == 2.0 ** 53                 # read, as doubles are
    with pytest.raises(ValueError, match=r"line 3, column 'y': 9007199254740992 and 9007199254740993 \(line 2\) "
                                         r"differ only beyond the 15-17 significant digits of a double"):
        number_column(frame, "y", distinct=True)
    path.write_text("id,y\na,0.100000000000000000000\nb,0.1\nc,1e-1\n")          # one number, written three ways
    assert number_column(read_csv(path), "y", distinct=True).tolist() == [0.1, 0.1, 0.1]


def test_whole_numbers_are_written_in_their_short_form():
    assert [format_exact(v) for v in (15.0, -3.0, 1e16, 0.5, -0.0)] == ["15", "-3", "1e+16", "0.5", "-0.0"]
    assert all(float(format_exact(v)) == v for v in (0.1, 1 / 3, 2.0 ** 53 + 2, 5e-324, 1.7976931348623157e308))
