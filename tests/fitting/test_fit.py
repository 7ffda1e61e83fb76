"""The calibration's least-squares core (softrnn.fitting) on models with known answers:
ordinary least squares' estimates and standard errors, a degenerate pair flagged, failed trials
penalised and counted, the finite-difference batch on several workers equal to the serial one."""

import numpy as np
import pytest

from softrnn.errors import SimulationError, SoftrnnInputError
from softrnn.fitting import FitOptions, Parameter, fit

T = np.linspace(0.0, 1.0, 50)


class Line:
    """y = a t + b (linear parameters: least squares has a closed form)."""

    def __call__(self, v):
        a, b = v
        return a * T + b


class Product:
    """y = a b t: only the product a b is fixed by the data."""

    def __call__(self, v):
        return v[0] * v[1] * T


class Fragile:
    """y = exp(-k t), unstable for k > 0.6 (like a simulation with too stiff a trial value)."""

    def __call__(self, v):
        if v[0] > 0.6:
            raise SimulationError("the rod went unstable")
        return np.exp(-v[0] * T)


def test_linear_model_gives_the_ordinary_least_squares_estimates_and_standard_errors():
    rng = np.random.default_rng(4)
    y = 2.0 * T - 0.5 + rng.normal(0.0, 0.05, T.size)
    result = fit(Line(), y, [Parameter("a", 1.0, -10.0, 10.0), Parameter("b", 0.0, -10.0, 10.0)])
    X = np.stack([T, np.ones_like(T)], 1)
    coef, res, *_ = np.linalg.lstsq(X, y, rcond=None)
    s2 = float(res[0]) / (T.size - 2)
    se = np.sqrt(np.diag(s2 * np.linalg.inv(X.T @ X)))
    np.testing.assert_allclose(result.fitted, coef, rtol=1e-6)
    np.testing.assert_allclose(result.std_error, se, rtol=1e-3)
    assert result.not_identifiable == [] and result.failed_trials == 0


def test_a_pair_that_enters_only_as_a_product_is_flagged_even_on_an_exact_fit():
    result = fit(Product(), 1.5 * T, [Parameter("a", 1.0, 0.1, 10.0), Parameter("b", 1.0, 0.1, 10.0)])
    assert result.fitted[0] * result.fitted[1] == pytest.approx(1.5, rel=1e-6)
    assert any("a and b: correlated" in line for line in result.not_identifiable)


def test_failed_trials_are_penalised_counted_and_the_fit_goes_on():
    y = np.exp(-0.5 * T)
    result = fit(Fragile(), y, [Parameter("k", 0.1, 0.01, 10.0)], options=FitOptions(max_evaluations=30))
    assert result.fitted[0] == pytest.approx(0.5, rel=1e-5)   # the first step overshoots into the unstable range
    assert result.failed_trials >= 1 and result.trials > result.failed_trials
    with pytest.raises(SoftrnnInputError, match=r"the simulation fails at the start values \{'k': 5.0\}: the rod "
                                                r"went unstable; start from values the simulator can run"):
        fit(Fragile(), y, [Parameter("k", 5.0, 0.01, 10.0)])


@pytest.mark.parametrize("kwargs, match", [
    (dict(start=0.0, lower=1.0, upper=2.0), r"k.start=0.0 is invalid: a start within its bounds \[1, 2\]"),
    (dict(start=1.0, lower=2.0, upper=1.0), r"k.bounds=\[2.0, 1.0\] is invalid: \[lower, upper\] with lower < upper"),
    (dict(start=float("nan"), lower=0.0, upper=1.0), r"k.start=nan is invalid: a finite number"),
])
def test_bad_parameters_are_one_line_errors(kwargs, match):
    with pytest.raises(SoftrnnInputError, match=match):
        Parameter("k", **kwargs)


def test_the_simulations_on_dask_workers_give_the_serial_fit_bit_for_bit():
    from softrnn.calibration.parallel import Evaluator

    rng = np.random.default_rng(5)
    y = np.exp(-0.7 * T) + rng.normal(0.0, 0.01, T.size)
    params = [Parameter("k", 0.2, 0.01, 10.0)]
    serial = fit(Fragile(), y, params)
    with Evaluator(workers=2) as evaluator:
        parallel = fit(Fragile(), y, params, evaluator=evaluator)
    assert parallel.fitted[0] == serial.fitted[0] and parallel.std_error[0] == serial.std_error[0]
    assert parallel.trials >= serial.trials                 # the speculative batches may try a few points more
