"""The misaligned-expectations illustration: following the supervisor's own set removes the false alarms;
bad inputs (a table)."""

import numpy as np
import pytest

from mutual.study.misalignment import straight_approach_starts, supervised_approaches
from mutual.supervision.supervisor import NoisySupervisor

from helpers.study import Lib, case_id, member, resolve


def test_following_the_supervisors_set_removes_false_alarms(functions):
    # Fig. 5.1: a supervisor with a gentler internal model alarms at every late (Standard) turn; robots that avoid
    # at alpha = mu + 2 sigma of the supervisor's own set draw (almost) no alarms, at alpha = mu about half
    library, _ = functions
    sup = NoisySupervisor(member(library, 0.5), 0.3, 0.05)
    starts = straight_approach_starts(60, np.random.default_rng(0))
    share = {a: supervised_approaches(v, a, sup, starts, np.random.default_rng(1))["intervened"].mean()
             for v, a in [(member(library, 1.0), 0.0), (sup.value_fn, 0.3), (sup.value_fn, 0.4)]}
    ignoring, at_mu, at_2sigma = share.values()
    assert ignoring == 1.0
    assert 0.25 < at_mu < 0.75
    assert at_2sigma <= 0.1


CASES = [
    (straight_approach_starts, (0, np.random.default_rng(0)), {}, ValueError, "n must be a positive integer"),
    (supervised_approaches, (Lib(1.0), 0.0, Lib(supervisor=0.5), [[0.0, 0.0]], np.random.default_rng(0)), {},
     ValueError, "starts must be a finite (n, 3) array"),
    (supervised_approaches, (Lib(1.0), 0.0, "supervisor", [[-7.0, 0.0, 0.0]], np.random.default_rng(0)), {},
     ValueError, "supervisor must be a NoisySupervisor"),
]


@pytest.mark.parametrize("function, args, kwargs, exception, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_is_named(function, args, kwargs, exception, phrase, tmp_path, functions):
    args = [resolve(a, tmp_path, functions) for a in args]
    with pytest.raises(exception) as info:
        function(*args, **kwargs)
    assert phrase in str(info.value)
