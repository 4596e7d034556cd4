"""Constraint text (``regions.parse_region``): what cannot be read is explained."""

import pytest

from mutual.constraints.continuous import parse_region


@pytest.mark.parametrize("text, phrase", [
    ("theta_dot <= fast", "expected 1 numbers"),
    ("disk 0 0", "expected 3 numbers"),
    ("disk 0 0 -1", "radius must be positive"),
    ("box 1 0 0 1", "XMIN < XMAX"),
    ("theta_dot == 3", "write 'NAME <= VALUE'"),
])
def test_bad_constraint_text_is_explained(text, phrase):
    with pytest.raises(ValueError, match=phrase):
        parse_region(text, ("theta", "theta_dot"))
