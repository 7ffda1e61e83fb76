"""Magnetics: dipole field and gradient, actuation matrix, magnet moments and wrenches (magnetic.md §2.6)."""

import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.magnetics import (
    GRADES,
    MU0,
    Coil,
    CoilLayout,
    Magnet,
    actuation_matrix,
    bigmag_like,
    dipole_field,
    dipole_gradient,
    field,
    force,
    force_matrix,
    gradient,
    moment_world,
    pack5,
    torque,
    unit_field_maps,
    unpack5,
    wrench,
    wrench_matrix,
)
from softrnn.magnetics.coils import field_gradient_into
from softrnn.rod.so3 import cay

RNG_SEED = 20210318


def _random_points(rng, n, radius=0.04):
    return rng.uniform(-radius, radius, size=(n, 3))


def _fd_gradient(fun, p, eps=1e-6):
    """Central differences: J_ij = d fun_i / d x_j at p (3,)."""
    cols = []
    for j in range(3):
        e = np.zeros(3)
        e[j] = eps
        cols.append((fun(p + e) - fun(p - e)) / (2 * eps))
    return np.stack(cols, -1)


# --------------------------------------------------------------------------- single dipole
def test_on_axis_field_is_mu0_m_over_2pi_d3():
    m, d = 3.7, 0.11
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    B = dipole_field(m * axis, np.zeros(3), d * axis)
    np.testing.assert_allclose(B, MU0 * m / (2 * math.pi * d**3) * axis, rtol=1e-13)
    # broadside: half the on-axis field, antiparallel to m
    side = np.cross(axis, [1.0, 0, 0])
    side /= np.linalg.norm(side)
    np.testing.assert_allclose(dipole_field(m * axis, np.zeros(3), d * side),
                               -MU0 * m / (4 * math.pi * d**3) * axis, rtol=1e-12, atol=1e-20)


def test_gradient_is_the_finite_difference_of_the_field_symmetric_and_traceless():
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(5):
        m = rng.normal(size=3) * 5.0
        c = rng.normal(size=3)
        c *= 0.12 / np.linalg.norm(c)
        p = _random_points(rng, 1)[0]
        G = dipole_gradient(m, c, p)
        G_fd = _fd_gradient(lambda x, m=m, c=c: dipole_field(m, c, x), p)
        np.testing.assert_allclose(G, G_fd, rtol=0, atol=1e-8 * np.abs(G).max())
        np.testing.assert_allclose(G, G.T, atol=1e-15 * np.abs(G).max())
        assert abs(np.trace(G)) <= 1e-13 * np.abs(G).max()


def test_pack5_unpack5_round_trip():
    rng = np.random.default_rng(RNG_SEED)
    g = rng.normal(size=(4, 5))
    G = unpack5(g)
    np.testing.assert_allclose(G, np.swapaxes(G, -1, -2))
    np.testing.assert_allclose(np.trace(G, axis1=-2, axis2=-1), 0.0, atol=1e-15)
    np.testing.assert_array_equal(pack5(G), g)


# --------------------------------------------------------------------------- magnet wrench
def test_force_is_the_gradient_of_mu_dot_B_and_equals_M_mu_g():
    rng = np.random.default_rng(RNG_SEED + 1)
    layout = bigmag_like()
    I = rng.uniform(-8, 8, size=6)
    for p in _random_points(rng, 4):
        mu = rng.normal(size=3) * 8e-3
        G = gradient(layout, p, I)
        f = force(mu, G)
        f_fd = _fd_gradient(lambda x, mu=mu: np.atleast_1d(mu @ field(layout, x, I)), p)[0]
        np.testing.assert_allclose(f, f_fd, rtol=1e-7)
        np.testing.assert_allclose(force_matrix(mu) @ pack5(G), f, rtol=1e-12)
        np.testing.assert_allclose(G.T @ mu, f, rtol=1e-12)


def test_torque_vanishes_when_mu_is_parallel_to_B_and_is_mu_B_sin_angle():
    B = np.array([0.003, -0.012, 0.007])
    for s in (2e-3, -5e-3):
        np.testing.assert_allclose(torque(s * B, B), 0.0, atol=1e-22)
    rng = np.random.default_rng(RNG_SEED + 2)
    for _ in range(5):
        mu = rng.normal(size=3) * 8e-3
        angle = math.acos(np.dot(mu, B) / (np.linalg.norm(mu) * np.linalg.norm(B)))
        tau = torque(mu, B)
        assert abs(np.linalg.norm(tau) - np.linalg.norm(mu) * np.linalg.norm(B) * math.sin(angle)) <= 1e-12 * \
            np.linalg.norm(mu) * np.linalg.norm(B)
        assert abs(np.dot(tau, mu)) < 1e-20 and abs(np.dot(tau, B)) < 1e-20


def test_wrench_matrix_times_actuation_matrix_gives_the_wrench():
    rng = np.random.default_rng(RNG_SEED + 3)
    layout = bigmag_like()
    p = _random_points(rng, 1)[0]
    I = rng.uniform(-8, 8, size=6)
    mu = rng.normal(size=3) * 8e-3
    W = wrench_matrix(mu) @ actuation_matrix(layout, p) @ I
    np.testing.assert_allclose(W, wrench(mu, field(layout, p, I), gradient(layout, p, I)), rtol=1e-12)


def test_magnet_moment_from_grade_and_volume():
    # magnetic.md §3: a 2 mm cube gives 8.59e-3 A m^2 (N45) and 8.28e-3 A m^2 (N42)
    assert GRADES == {"N42": 1.30, "N45": 1.35}
    assert Magnet(arc_length=0.01, grade="N45").moment == pytest.approx(8.594e-3, rel=1e-3)
    assert Magnet(arc_length=0.01, grade="N42").moment == pytest.approx(8.276e-3, rel=1e-3)
    m = Magnet(arc_length=0.01, remanence=1.2, size=(1e-3, 2e-3, 3e-3), direction=(0, 0, -2))
    assert m.moment == pytest.approx(1.2 * 6e-9 / MU0, rel=1e-14)
    np.testing.assert_allclose(m.moment_body, [0, 0, -m.moment])
    assert m.scaled(1.03).br == pytest.approx(1.2 * 1.03)
    R = cay(np.array([0.3, -0.2, 0.5]))
    np.testing.assert_allclose(moment_world(m, R), R[:, 2] * -m.moment, rtol=1e-14)


# --------------------------------------------------------------------------- coil layout
def test_default_layout_centre_field_rank_and_gradient():
    layout = bigmag_like()
    assert layout.n_coils == 6 and layout.current_limit == 8.0
    A = actuation_matrix(layout, np.zeros(3))
    assert A.shape == (8, 6)
    assert np.linalg.matrix_rank(A) == 6
    assert np.linalg.matrix_rank(A[:3]) == 3
    # magnetic.md §1.2: field block singular values 1.5, 1.5, 1.22 mT/A
    np.testing.assert_allclose(np.linalg.svd(A[:3], compute_uv=False), [1.5e-3, 1.5e-3, 1.2247e-3], rtol=1e-3)
    for k, coil in enumerate(layout.coils):
        a = np.asarray(coil.axis)
        np.testing.assert_allclose(A[:3, k], 1.0e-3 * a, rtol=1e-12)           # 1 mT/A along a_k
        np.testing.assert_allclose(np.linalg.norm(coil.position), 0.12)
        assert coil.kappa == pytest.approx(8.64, rel=1e-3)                     # 2 pi R^3 b0 / mu0
        # on the axis G = 3 mu0 kappa / (4 pi R^4) (I - 3 a a^T), scale 12.5 mT/m per A (magnetic.md §1.2):
        # -25 mT/m per A along the axis (the field decays away from the coil), +12.5 across it
        scale = 3 * MU0 * coil.kappa / (4 * math.pi * 0.12**4)
        assert scale == pytest.approx(12.5e-3, rel=1e-3)
        np.testing.assert_allclose(unpack5(A[3:, k]), scale * (np.eye(3) - 3 * np.outer(a, a)), atol=1e-14)
    elevations = [math.degrees(math.asin(c.position[2] / 0.12)) for c in layout.coils]
    np.testing.assert_allclose(elevations, [30, -30, 30, -30, 30, -30], atol=1e-12)


def test_layout_maps_are_linear_in_current_and_vectorised_over_points():
    rng = np.random.default_rng(RNG_SEED + 4)
    layout = bigmag_like()
    P = _random_points(rng, 7)
    I = rng.uniform(-8, 8, size=6)
    B = field(layout, P, I)
    G = gradient(layout, P, I)
    A = actuation_matrix(layout, P)
    assert B.shape == (7, 3) and G.shape == (7, 3, 3) and A.shape == (7, 8, 6)
    for i, p in enumerate(P):
        direct = sum(dipole_field(c.moment_per_ampere * I[k], c.position, p) for k, c in enumerate(layout.coils))
        np.testing.assert_allclose(B[i], direct, rtol=1e-12)
        np.testing.assert_allclose(field(layout, p, I), B[i], rtol=1e-14)
        np.testing.assert_allclose(A[i] @ I, np.concatenate([B[i], pack5(G[i])]), rtol=1e-12, atol=1e-18)
    beta, grads = unit_field_maps(layout, P)
    np.testing.assert_allclose(np.einsum("pkij,k->pij", grads, 2 * I), 2 * G, rtol=1e-14)


def test_numba_kernel_matches_numpy():
    rng = np.random.default_rng(RNG_SEED + 5)
    layout = bigmag_like()
    I = rng.uniform(-8, 8, size=6)
    B = np.empty(3)
    G = np.empty((3, 3))
    for p in _random_points(rng, 5):
        d = field_gradient_into(layout.positions, layout.moments_per_ampere, I, p[0], p[1], p[2], B, G)
        np.testing.assert_allclose(B, field(layout, p, I), rtol=1e-12)
        np.testing.assert_allclose(G, gradient(layout, p, I), rtol=1e-11, atol=1e-14)
        assert d == pytest.approx(np.min(np.linalg.norm(layout.positions - p, axis=1)))


def test_coil_strength_from_b0_off_axis():
    # a coil whose axis is not aimed at the centre: b0 is still the field magnitude there
    coil = Coil(position=(0.0, 0.0, 0.2), axis=(1.0, 0.0, 0.0), b0=2e-3)
    B = dipole_field(coil.moment_per_ampere, coil.position, np.zeros(3))
    assert np.linalg.norm(B) == pytest.approx(2e-3, rel=1e-12)
    assert Coil(position=(0.2, 0, 0), axis=(-1, 0, 0), kappa=3.0).kappa == 3.0


# --------------------------------------------------------------------------- bad input: one-line messages
@pytest.mark.parametrize("make, match", [
    (lambda: bigmag_like(radius=0.06),
     r"coils\[0\]\.position=.* is invalid: a coil outside the workspace: \|position\| = 0.06 m"),
    (lambda: CoilLayout(coils=(Coil(position=(0.03, 0, 0), axis=(1, 0, 0), b0=1e-3),)),
     "coil outside the workspace"),
    (lambda: Coil(position=(0.2, 0, 0), axis=(1, 0, 0)), "exactly one of kappa"),
    (lambda: Coil(position=(0.2, 0, 0), axis=(0, 0, 0), kappa=1.0), "coil.axis"),
    (lambda: Magnet(arc_length=0.01, grade="N52"), "magnet.grade='N52' is invalid"),
    (lambda: Magnet(arc_length=0.01, size=(1e-3, -1e-3, 1e-3)), "magnet.size"),
    (lambda: field(bigmag_like(), np.zeros(3), [9.0, 0, 0, 0, 0, 0]), r"max \|currents\|=9.0 is invalid: .*8 A"),
    (lambda: field(bigmag_like(), np.zeros(3), [1.0, 0, 0]), r"currents.shape=\(3,\) is invalid"),
    (lambda: field(bigmag_like(), np.zeros(3), [np.nan] * 6), "finite currents"),
    (lambda: field(bigmag_like(), bigmag_like().positions[2] * 0.9, np.zeros(6)), "at least 0.02 m from every coil"),
    (lambda: actuation_matrix(bigmag_like(), np.zeros(4)), r"points.shape=\(4,\) is invalid"),
])
def test_bad_input_gives_a_one_line_message(make, match):
    with pytest.raises(SoftrnnInputError, match=match) as err:
        make()
    assert "\n" not in str(err.value)
