"""Load and path constructors validate their input with one-line errors."""

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod.loads import CirclePath, Constant, Figure8Path, SquarePath


@pytest.mark.parametrize("cls, kwargs, words", [
    (SquarePath, dict(center="abc", side=0.2, period=1.0), "SquarePath.center='abc'"),
    (SquarePath, dict(center=(0, 0, 0), side=0.2, period=1.0, ramp=-1.0), "SquarePath.ramp=-1.0"),
    (CirclePath, dict(center=(0, 0, 0), radius=0.1, period=1.0, u=(0, 0, 0)), "CirclePath.u/v"),
    (Figure8Path, dict(center=(0, 0, 0), width=0.1, height=0.1, period=0.0), "Figure8Path.period=0.0"),
])
def test_paths_reject_bad_input(cls, kwargs, words):
    with pytest.raises(SoftrnnInputError, match=words.replace(".", r"\.").replace("(", r"\(")):
        cls(**kwargs)


def test_constant_rejects_non_numbers_and_paths_start_at_centre():
    with pytest.raises(SoftrnnInputError, match="Constant.value"):
        Constant(("a", 0, 0))
    t = np.array([0.0, 0.5, 2.0])
    for path in (SquarePath(center=(1, 2, 3), side=0.2, period=4.0),
                 CirclePath(center=(1, 2, 3), radius=0.1, period=4.0)):
        np.testing.assert_allclose(path(t)[0], (1, 2, 3))
