"""Why a fit stopped, in plain words: ``least_squares``' status codes mapped to sentences that name
the tolerance or the budget, never SciPy's own termination message."""

import pytest

from softrnn.fitting import FitOptions, stop_reason

OPTIONS = FitOptions(max_evaluations=40, xtol=1e-6, ftol=1e-8, gtol=1e-10)


@pytest.mark.parametrize("status, words", [
    (1, ["gradient fell below gtol = 1e-10", "after 12 evaluations"]),
    (2, ["cost decreased by less than ftol = 1e-08"]),
    (3, ["step became smaller than xtol = 1e-06"]),
    (4, ["ftol = 1e-08", "xtol = 1e-06"]),
    (0, ["evaluation budget", "max_evaluations = 40", "ran out"]),
    (-1, ["rejected its inputs"]),
    (7, ["status 7"]),
])
def test_each_status_is_a_plain_sentence(status, words):
    text = stop_reason(status, 12, OPTIONS)
    assert all(w in text for w in words), text
    assert "\n" not in text and "termination condition" not in text and "`" not in text


def test_one_evaluation_is_singular():
    assert stop_reason(1, 1, OPTIONS).endswith("after 1 evaluation")
