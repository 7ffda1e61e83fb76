"""The PyElastica comparison's own ingredients (benchmarks/vs_pyelastica.py): its analytic references,
its frequency measurement, and that both codes really get the same rod. Skipped without the
optional PyElastica extra; no timing is asserted (that is the benchmark's job)."""

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

pytest.importorskip("elastica")

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "vs_pyelastica.py"
FIT_RTOL = 1e-6          # frequency fit on an exact two-mode signal
EXACT_RTOL = 5e-5        # Rayleigh's first-order correction vs the exact Timoshenko frequency
REFERENCE_RTOL = 5e-4    # corrected frequency vs softrnn's frequency (L/r = 20, 50 segments)
CORRECTION_MIN = 4e-3    # at L/r = 20 rotary inertia + shear must matter (about -0.59 %)
MATCH_RTOL = 1e-12       # lumped masses and stiffnesses of the two codes


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("vs_pyelastica", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_static_reference_is_euler_bernoulli_plus_timoshenko_shear(bench):
    c = bench.Cantilever()
    P, L = c.tip_load, c.length
    EI = c.youngs_modulus * math.pi * c.radius**4 / 4
    GA = c.shear_modulus * math.pi * c.radius**2
    ref = bench.static_tip_deflection(c)
    assert ref["euler_bernoulli_m"] == pytest.approx(c.load_fraction * L, rel=1e-12)
    assert ref["deflection_m"] == pytest.approx(P * L**3 / (3 * EI) + P * L / (27 / 28 * GA), rel=1e-12)


def test_mode_shape_ratios_and_slender_limit(bench):
    """int phi'^2/int phi^2 = int phi'''^2/int phi''^2 for the first clamped-free mode (integration by
    parts with the boundary conditions); the slender benchmark rod is within 0.03 % of Euler-Bernoulli."""
    rot, shear = bench.mode_shape_ratios()
    assert rot == pytest.approx(shear, rel=1e-8)
    assert rot == pytest.approx(4.6478, rel=1e-4)
    c = bench.Cantilever()
    f = bench.first_bending_frequency(c)
    A, I = math.pi * c.radius**2, math.pi * c.radius**4 / 4
    eb = 1.8751**2 * math.sqrt(c.youngs_modulus * I / (c.density * A * c.length**4)) / (2 * math.pi)
    assert f["euler_bernoulli_hz"] == pytest.approx(eb, rel=1e-4)
    assert -3e-4 < f["correction"] < -2e-4


def test_frequency_fit_ignores_the_second_mode(bench):
    f1 = 0.0884
    t = np.arange(0.0, 4.0 / f1, 1.0 / (200 * f1))
    w = 2 * np.pi * f1
    z = 0.01 * (1 - 0.965 * np.cos(w * t) - 0.03 * np.cos(6.2 * w * t))
    fit = bench.oscillation_frequency(t, z)
    assert fit["frequency_hz"] == pytest.approx(f1, rel=FIT_RTOL)
    assert fit["second_mode_hz"] == pytest.approx(6.2 * f1, rel=1e-4)
    assert abs(fit["crossing_estimate_hz"] / f1 - 1) > 10 * FIT_RTOL  # what the fit corrects


def timoshenko_cantilever_frequency(c, guess_hz):
    """Exact first frequency [Hz] of the linear Timoshenko cantilever (shear + rotary inertia):
    harmonic amplitudes y = (w, psi, M, Q) obey w' = psi + Q/(kGA), psi' = M/EI,
    M' = -Q - rho I w^2 psi, Q' = -rho A w^2 w, with w = psi = 0 at the clamp and M = Q = 0 at the
    tip; the root of the 2x2 shooting determinant."""
    EI, kGA = c.bending_stiffness, c.shear_stiffness
    rA, rI = c.density * c.area, c.density * c.second_moment

    def tip_determinant(omega):
        def rhs(_, y):
            return [y[1] + y[3] / kGA, y[2] / EI, -y[3] - rI * omega**2 * y[1], -rA * omega**2 * y[0]]

        ends = [solve_ivp(rhs, (0.0, c.length), y0, rtol=1e-12, atol=1e-14, method="DOP853").y[2:, -1]
                for y0 in ([0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0])]
        return np.linalg.det(np.array(ends))

    w = 2 * np.pi * guess_hz
    with np.errstate(under="ignore"):  # solve_ivp's step-size control underflows harmlessly
        return brentq(tip_determinant, 0.95 * w, 1.05 * w, xtol=1e-13) / (2 * np.pi)


@pytest.mark.parametrize("slenderness", [20, 100])
def test_rayleigh_correction_matches_exact_timoshenko_frequency(bench, slenderness):
    c = bench.Cantilever(length=0.01 * slenderness, radius=0.01, youngs_modulus=1e7, shear_modulus=1e7 / 3)
    ref = bench.first_bending_frequency(c)
    exact = timoshenko_cantilever_frequency(c, ref["frequency_hz"])
    assert ref["frequency_hz"] == pytest.approx(exact, rel=EXACT_RTOL)
    assert ref["correction"] == pytest.approx(exact / ref["euler_bernoulli_hz"] - 1, rel=0.01)


def test_corrected_frequency_matches_softrnn_on_a_stubby_rod(bench):
    """L/r = 20: rotary inertia and shear lower the frequency by ~0.6 %; softrnn (50 segments, step
    load as in the benchmark but 10x smaller, linear) agrees with the corrected formula, not with
    Euler-Bernoulli. (At the benchmark's 1 % deflection this stubby rod is 0.19 % stiffer in both
    softrnn and PyElastica: a finite-amplitude effect; on the slender benchmark rod it is ~0.01 %.)"""
    c = bench.Cantilever(length=0.2, radius=0.01, youngs_modulus=1e7, shear_modulus=1e7 / 3, load_fraction=1e-3)
    ref = bench.first_bending_frequency(c)
    assert ref["correction"] < -CORRECTION_MIN
    test = bench.tests_for(c)[1]
    run = bench.softrnn_run(c, 50, test)
    measured = bench.evaluate(c, test, run)
    assert measured["stable"] and measured["crossings"] >= 7
    assert measured["frequency_hz"] == pytest.approx(ref["frequency_hz"], rel=REFERENCE_RTOL)
    assert abs(measured["frequency_hz"] / ref["euler_bernoulli_hz"] - 1) > CORRECTION_MIN


def test_both_codes_get_the_same_lumped_rod(bench):
    """Matched resolution: N elements in PyElastica = N + 1 nodes in softrnn, with equal node masses,
    bending stiffness EI and shear stiffness kappa G A (kappa = PyElastica's 27/28)."""
    c = bench.Cantilever()
    n = 10
    _, rod = bench.pyelastica_system(c, n, 0.0, 1e-4)
    lumped = bench.softrnn_setup(c, n, 0.0).rod.lumped()
    np.testing.assert_allclose(rod.mass, lumped["mass"], rtol=MATCH_RTOL)
    np.testing.assert_allclose(rod.shear_matrix[0, 0], lumped["C1"][:, 0], rtol=MATCH_RTOL)
    np.testing.assert_allclose(rod.shear_matrix[2, 2], lumped["C1"][:, 2], rtol=MATCH_RTOL)
    np.testing.assert_allclose(rod.bend_matrix[0, 0], lumped["C2"][:-1, 0], rtol=MATCH_RTOL)
    assert rod.position_collection.shape == (3, n + 1)


def test_script_exits_2_with_one_line_without_pyelastica(bench, monkeypatch, capsys):
    monkeypatch.setitem(__import__("sys").modules, "elastica", None)  # import elastica -> ImportError
    assert bench.main([]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "PyElastica is not installed" in err


def test_bad_cantilever_names_argument_and_value(bench):
    from softrnn.errors import SoftrnnInputError

    with pytest.raises(SoftrnnInputError, match=r"Cantilever\.radius=2\.0 is invalid"):
        bench.Cantilever(radius=2.0)
    with pytest.raises(SoftrnnInputError, match=r"Cantilever\.density=-1\.0 is invalid"):
        bench.Cantilever(density=-1.0)
