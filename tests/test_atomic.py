"""Atomic writes (``mutual.atomic``): a failure leaves nothing behind."""

import pytest

from mutual.atomic import atomic_path


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "fig.png"
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []
