"""Seeds (``mutual.seeds``): valid seeds give generators."""

import numpy as np
import pytest

from mutual.seeds import generator


@pytest.mark.parametrize("seed", [0, 7, np.int64(7), np.uint8(7), None, np.random.default_rng(7)])
def test_valid_seeds_give_generators(seed):
    rng = generator(seed)
    assert isinstance(rng, np.random.Generator)
    if seed is not None and not isinstance(seed, np.random.Generator):
        assert rng.random() == np.random.default_rng(int(seed)).random()
