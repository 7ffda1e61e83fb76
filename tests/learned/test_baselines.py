"""Baselines for learned models: persistence and constant velocity by hand, constant velocity exact
on uniform motion, the linear autoregressive model recovering a damped oscillator in closed form and
a damped mass-spring chain, free running (reference-driven columns, divergence), horizon errors
(zero for an oracle, exact for persistence on uniform motion), one-line input errors, determinism,
and no PyTorch import."""

import subprocess
import sys
from functools import partial

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.learned.baselines import (
    MAX_MANIPULATOR_FEATURES,
    ConstantVelocity,
    LinearAR,
    LinearARConfig,
    Persistence,
    free_run,
    horizon_errors,
    one_step,
    standard_baselines,
)
from softrnn.learned.node.manipulator import RolloutDiverged

# damped oscillator x[k] = a x[k-1] + b x[k-2] + c u[k-1] (per axis), poles r exp(+-i theta)
RADIUS, THETA, GAIN = 0.995, 0.05, 1e-3
A, B = 2.0 * RADIUS * np.cos(THETA), -RADIUS ** 2


def oscillator(T: int = 3000, seed: int = 0):
    """Positions (T, 1, 3) [m] and forces (T, 1, 3) [N] of the oscillator in closed form: the free
    response amp r^k cos(theta k + phase) plus the forced one, the impulse response
    h[j] = r^j sin((j+1) theta) / sin(theta) convolved with c u (zero initial conditions)."""
    rng = np.random.default_rng(seed)
    k = np.arange(T)
    u = rng.normal(size=(T, 3))
    h = RADIUS ** k * np.sin((k + 1) * THETA) / np.sin(THETA)
    x = np.empty((T, 3))
    for d in range(3):
        forced = np.concatenate([[0.0], np.convolve(h, u[:, d])[:T - 1]])
        x[:, d] = 0.05 * (d + 1) * RADIUS ** k * np.cos(THETA * k + 0.7 * d) + GAIN * forced
    return x[:, None, :], u[:, None, :]


def spring_chain(T: int = 6000, n: int = 6, seed: int = 1):
    """A damped mass-spring chain along x (unit masses, spacing 0.1 m): column 0 clamped, column n-1
    free and pushed by a random force in 3 axes; semi-implicit Euler, h = 0.01 s, stiffness 100 N/m,
    damping 0.5 N s/m. Positions (T, n, 3) [m] and forces (T, n, 3) [N] (zero off the tip)."""
    h, stiff, damp = 0.01, 100.0, 0.5
    rng = np.random.default_rng(seed)
    f = np.zeros((T, n, 3))
    f[:, -1] = rng.normal(size=(T, 3))
    u, v = np.zeros((T, n, 3)), np.zeros((n, 3))
    for k in range(1, T):
        left = u[k - 1, :-1] - u[k - 1, 1:]                     # (n-1, 3) pull of the left neighbour
        acc = np.zeros((n, 3))
        acc[1:] += stiff * left
        acc[1:-1] -= stiff * left[1:]                           # pull of the right neighbour
        acc += f[k - 1] - damp * v
        acc[0] = 0.0
        v = v + h * acc
        v[0] = 0.0
        u[k] = u[k - 1] + h * v
    rest = np.zeros((n, 3))
    rest[:, 0] = 0.1 * np.arange(n)
    return rest + u, f


# ------------------------------------------------------------------------------------- simple baselines
def test_persistence_and_constant_velocity_by_hand():
    P = np.array([[[0.0, 0, 0], [1, 2, 3]],
                  [[1.0, 0, 0], [1, 2, 5]],
                  [[3.0, 0, 0], [1, 2, 4]],
                  [[4.0, 1, 0], [0, 2, 4]]])                      # (T=4, N=2, 3)
    assert np.array_equal(Persistence().step(P[:2]), P[1])
    assert np.array_equal(ConstantVelocity().step(P[:2]), [[2.0, 0, 0], [1, 2, 7]])
    assert np.array_equal(ConstantVelocity().step(P[:3]), [[5.0, 0, 0], [1, 2, 3]])   # the last two rows
    assert np.array_equal(one_step(Persistence(), P, None, 1, 4), P[:3])
    assert np.array_equal(one_step(ConstantVelocity(), P, None, 2, 4), [[[2.0, 0, 0], [1, 2, 7]],
                                                                        [[5.0, 0, 0], [1, 2, 3]]])
    # free running: row 2 = 2 P1 - P0 = (2, 0, 0); row 3 = 2 row2 - P1 = (3, 0, 0)
    assert np.array_equal(free_run(ConstantVelocity(), P, None, 2, 4, modelled=[0])[:, 0], [[2.0, 0, 0],
                                                                                          [3.0, 0, 0]])
    assert np.array_equal(free_run(Persistence(), P, None, 1, 4), np.repeat(P[:1], 3, axis=0))


def test_constant_velocity_is_exact_on_uniform_motion_and_persistence_is_not():
    dt, T = 0.01, 600
    r0 = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.2, 0.05, 0.0]])
    vel = np.array([[0.0, 0.0, 0.0], [0.3, -0.2, 0.1], [-0.1, 0.4, 0.2]])            # m/s
    P = r0 + vel * dt * np.arange(T)[:, None, None]                                  # (T, 3, 3)
    cv = free_run(ConstantVelocity(), P, None, 100, T)
    assert np.abs(cv - P[100:]).max() < 1e-12
    still = free_run(Persistence(), P, None, 100, T)
    steps = np.arange(1, T - 100 + 1)[:, None, None]
    np.testing.assert_allclose(np.abs(still - P[100:]), np.abs(vel) * dt * steps, rtol=1e-9, atol=1e-15)
    assert np.abs(still - P[100:]).max() > 0.1


# ------------------------------------------------------------------------------------- LinearAR
def test_linear_ar_recovers_a_damped_oscillator():
    X, U = oscillator()
    model = LinearAR.fit(LinearARConfig(history=2, neighbours=(), relative=False, alpha=1e-12), X, U, 0, 2000)
    weights, intercept = model.coefficients(0)
    names = model.feature_names(0)
    expected = np.zeros((12, 3))
    for d, axis in enumerate("xyz"):
        expected[names.index(f"position k-1 col 0 {axis}"), d] = A - 1.0     # the target is the increment
        expected[names.index(f"position k-2 col 0 {axis}"), d] = B
        expected[names.index(f"force k-1 col 0 {axis}"), d] = GAIN
    np.testing.assert_allclose(weights, expected, rtol=0, atol=1e-8)
    np.testing.assert_allclose(intercept, 0.0, rtol=0, atol=1e-10)
    run = free_run(model, X, U, 2000, 3000)                                          # 1000 steps
    assert np.abs(run - X[2000:]).max() < 1e-6 * np.abs(X[2000:]).max()


def test_relative_features_give_the_same_model_with_a_smaller_ridge_bias():
    X, U = oscillator()
    config = dict(history=2, neighbours=(), alpha=1e-14)
    absolute = LinearAR.fit(LinearARConfig(relative=False, **config), X, U, 0, 2000)
    relative = LinearAR.fit(LinearARConfig(relative=True, **config), X, U, 0, 2000)
    np.testing.assert_allclose(one_step(relative, X, U, 2000, 3000), one_step(absolute, X, U, 2000, 3000),
                               rtol=0, atol=1e-11)
    chosen = LinearAR.fit(LinearARConfig(history=2, neighbours=()), X, U, 0, 2000)   # alpha on validation
    assert chosen.alpha[0] <= 1e-6
    same_alpha = LinearAR.fit(LinearARConfig(history=2, neighbours=(), relative=False, alpha=float(chosen.alpha[0])),
                              X, U, 0, 2000)
    err_relative = np.abs(free_run(chosen, X, U, 2000, 3000) - X[2000:]).max()
    err_absolute = np.abs(free_run(same_alpha, X, U, 2000, 3000) - X[2000:]).max()
    assert err_relative < 1e-5 * np.abs(X[2000:]).max()
    assert err_relative < err_absolute / 100


@pytest.mark.parametrize("mode", ["node", "manipulator"])
def test_linear_ar_free_run_of_a_spring_chain_stays_on_the_system(mode):
    P, F = spring_chain()
    model = LinearAR.fit(LinearARConfig(mode=mode), P, F, 0, 3000, modelled=range(1, 6))
    run = free_run(model, P, F, 3000, 6000, modelled=model.modelled)                # 3000 steps
    amplitude = np.abs(P[3000:] - P[0]).max()
    assert np.isfinite(run).all()
    assert np.abs(run - P[3000:]).max() < 1e-4 * amplitude                         # persistence: ~ amplitude
    assert np.array_equal(run[:, 0], P[3000:, 0])                                   # the clamp


def test_free_run_keeps_unmodelled_columns_on_the_reference():
    rng = np.random.default_rng(3)
    P, W = rng.normal(size=(40, 4, 3)), rng.normal(size=(40, 4, 6))
    model = LinearAR.fit(LinearARConfig(next_wrench=True), P, W, 0, 25, modelled=[1, 2])
    run = free_run(model, P, W, 25, 40, modelled=[1, 2])
    assert np.array_equal(run[:, [0, 3]], P[25:, [0, 3]])
    assert not np.allclose(run[:, [1, 2]], P[25:, [1, 2]])
    held = free_run(Persistence(), P, None, 25, 40, modelled=[1, 3])
    assert np.array_equal(held[:, [0, 2]], P[25:, [0, 2]])
    assert np.array_equal(held[:, [1, 3]], np.broadcast_to(P[24, [1, 3]], (15, 2, 3)))


def test_one_step_is_step_on_each_reference_window():
    rng = np.random.default_rng(4)
    P, W = rng.normal(size=(60, 5, 3)), rng.normal(size=(60, 5, 6))
    model = LinearAR.fit(LinearARConfig(history=3, neighbours=2, next_wrench=True), P, W, 0, 40)
    batch = one_step(model, P, W, 40, 60)
    single = np.stack([model.step(P[k - 3:k], W[k - 3:k], W[k]) for k in range(40, 60)])
    np.testing.assert_allclose(batch, single, rtol=1e-12, atol=1e-14)


def test_fits_are_deterministic_and_leave_the_inputs_alone():
    P, F = spring_chain(T=1500)
    P0, F0 = P.copy(), F.copy()
    for mode in ("node", "manipulator"):
        one = LinearAR.fit(LinearARConfig(mode=mode), P, F, 0, 1000)
        two = LinearAR.fit(LinearARConfig(mode=mode), P, F, 0, 1000)
        assert np.array_equal(one.weights, two.weights) and np.array_equal(one.intercept, two.intercept)
        assert np.array_equal(one.alpha, two.alpha)
    assert np.array_equal(P, P0) and np.array_equal(F, F0)


# ------------------------------------------------------------------------------------- horizons
def test_horizon_errors_are_zero_for_an_oracle_and_skip_horizons_that_do_not_fit():
    P = np.random.default_rng(5).normal(size=(300, 3, 3))
    out = horizon_errors(lambda p, w, s, e: p[s:e].copy(), P, None, [5, 50, 150])
    assert sorted(out) == [1, 10, 100]                                               # 1000 does not fit
    for h in out:
        assert out[h] == {"max_abs_m": 0.0, "mean_abs_m": 0.0, "n_starts": 3, "diverged": 0}
    assert horizon_errors(lambda p, w, s, e: p[s:e].copy(), P, None, [250], stop=280)[10]["n_starts"] == 1


def test_persistence_horizon_error_is_speed_times_horizon():
    dt, speed = 0.01, 0.2
    P = np.zeros((500, 2, 3))
    P[:, 1, 0] = speed * dt * np.arange(500)
    out = horizon_errors(partial(free_run, Persistence()), P, None, [10, 200], (1, 10, 100), nodes=[1])
    for h in (1, 10, 100):
        assert out[h]["max_abs_m"] == pytest.approx(speed * dt * h, rel=1e-9)
        assert out[h]["mean_abs_m"] == pytest.approx(speed * dt * h / 3, rel=1e-9)   # y, z exact


class Doubling:
    """A baseline that doubles the last position (diverges)."""

    history = 1

    def step(self, window_positions, window_wrenches=None, next_wrench=None):
        return 2.0 * np.asarray(window_positions)[-1]


def test_a_diverging_baseline_is_reported():
    P = np.ones((200, 1, 3))
    with pytest.raises(RolloutDiverged, match="sample 5"):
        free_run(Doubling(), P, None, 1, 200)                                        # 2, 4, 8, 16, 32
    out = horizon_errors(partial(free_run, Doubling()), P, None, [1], (1, 4, 10))
    assert out[1]["max_abs_m"] == 1.0 and out[4]["max_abs_m"] == 15.0
    assert out[10] == {"max_abs_m": None, "mean_abs_m": None, "n_starts": 1, "diverged": 1}
    nan_after_3 = horizon_errors(lambda p, w, s, e: np.where(np.arange(e - s)[:, None, None] < 3, p[s:e], np.nan),
                                 P, None, [1, 2], (1, 3, 4))
    assert nan_after_3[3]["max_abs_m"] == 0.0 and nan_after_3[4]["diverged"] == 2


def test_standard_baselines_name_three_predictors():
    P, F = spring_chain(T=400)
    models = standard_baselines(P, F, 0, 300, modelled=range(1, 6))
    assert list(models) == ["persistence", "constant velocity", "linear"]
    assert [m.history for m in models.values()] == [1, 2, 2]


# ------------------------------------------------------------------------------------- errors
def _fitted():
    P, W = np.random.default_rng(6).normal(size=(30, 4, 3)), np.zeros((30, 4, 6))
    return LinearAR.fit(LinearARConfig(), P, W, 0, 20), P, W


BAD = {
    "history": (lambda: LinearARConfig(history=0), "history=0"),
    "mode": (lambda: LinearARConfig(mode="global"), "mode='global'"),
    "alpha": (lambda: LinearARConfig(alpha=0.0), "alpha=0.0"),
    "neighbours": (lambda: LinearARConfig(neighbours=(0, 1)), "neighbours="),
    "positions": (lambda: LinearAR.fit(LinearARConfig(), np.zeros((30, 4, 2))), "positions="),
    "wrenches": (lambda: LinearAR.fit(LinearARConfig(), np.zeros((30, 4, 3)), np.zeros((30, 4, 4))), "wrenches="),
    "short span": (lambda: LinearAR.fit(LinearARConfig(), np.zeros((30, 4, 3)), None, 10, 13), "stop=13"),
    "start": (lambda: free_run(ConstantVelocity(), np.zeros((30, 4, 3)), None, 1, 10), "start=1"),
    "stop": (lambda: free_run(Persistence(), np.zeros((30, 4, 3)), None, 5, 31), "stop=31"),
    "modelled": (lambda: free_run(Persistence(), np.zeros((30, 4, 3)), None, 5, 9, modelled=[4]), "modelled="),
    "window": (lambda: _fitted()[0].step(np.zeros((1, 4, 3)), np.zeros((1, 4, 6))), "window_positions="),
    "window wrenches": (lambda: _fitted()[0].step(np.zeros((2, 4, 3))), "window_wrenches=None"),
    "horizons": (lambda: horizon_errors(partial(free_run, Persistence()), np.zeros((9, 1, 3)), None, [1], (0,)),
                 "horizons="),
    "manipulator": (lambda: LinearAR.fit(LinearARConfig(mode="manipulator"),     # 3 x 2 features per node
                                         np.random.default_rng(0).normal(size=(8, MAX_MANIPULATOR_FEATURES // 6 + 1,
                                                                               3))),
                    "mode='manipulator'"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_is_one_line_naming_the_argument(case):
    call, words = BAD[case]
    with pytest.raises(SoftrnnInputError, match=words) as err:
        call()
    assert "\n" not in str(err.value)


def test_the_baselines_do_not_import_torch(tmp_path):
    code = ("import sys\nsys.modules['torch'] = None\nimport numpy as np\n"
            "from softrnn.learned.baselines import LinearAR, LinearARConfig, free_run\n"
            "P = np.random.default_rng(0).normal(size=(20, 3, 3))\n"
            "free_run(LinearAR.fit(LinearARConfig(), P, None, 0, 12), P, None, 12, 20)\n"
            "print('torch' in sys.modules and sys.modules['torch'] is not None)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip() == "False"
