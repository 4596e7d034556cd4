"""Numbers written to CSV (``mutual.csvfile.format_exact``) read back exactly, and whole numbers keep their
short form."""

from mutual.csvfile import format_exact


def test_whole_numbers_keep_their_short_form(tmp_path):
    assert [format_exact(v) for v in (15.0, -3.0, 1e16, 0.5)] == ["15", "-3", "1e+16", "0.5"]
