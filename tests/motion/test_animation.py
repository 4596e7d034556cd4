"""The belief animations: deterministic, drawing every path; bad inputs (a table)."""

import hashlib

import numpy as np
import pytest

from mutual.motion import animation
from mutual.motion.evident import safety as es


def test_animation_is_deterministic_and_draws_every_path(tmp_path):
    task, w0, w1 = es.figure_scenario("7.1", steps=20)
    paths = es.solve_hypotheses(task, w0, w1)
    digests = []
    for i in range(2):
        anim = animation.task_belief_animation(task, w0, w1, paths, frames=5, title="test (simulated)")
        target = tmp_path / f"a{i}.gif"
        anim.save(target, writer="pillow", fps=5, dpi=40)
        digests.append(hashlib.sha256(target.read_bytes()).hexdigest())
    assert digests[0] == digests[1]
    ax, bx = anim._fig.axes
    assert len(bx.get_lines()) == 4  # three beliefs and the 1/2 line
    with pytest.raises(ValueError, match="frames"):
        animation.task_belief_animation(task, w0, w1, paths, frames=100)


PATH = np.c_[np.linspace(0, 1, 11), np.zeros(11)]


CASES = [
    (animation.belief_animation, ({"a": PATH}, {"a": np.full(11, 0.5)}, 0.1), {"frames": 1}, ValueError, "frames"),
    (animation.belief_animation, ({"a": PATH}, {"a": np.full(11, 1.5)}, 0.1), {}, ValueError, "probabilities"),
    (animation.belief_animation, ({"a": PATH}, {"b": np.full(11, 0.5)}, 0.1), {}, ValueError, "same names"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i}-{c[0].__name__}-{c[4][:24]}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args, **kwargs)
