"""Discrete strains, strain energy and internal loads (lgvi.md §2.2-2.4, §2.10 item 2): the loads
are exactly minus the gradient of the discrete strain energy, in the NumPy reference
(softrnn.rod.discrete) and in the numba kernel."""

import numpy as np
import pytest

from softrnn.rod import NodeOverride, RodSpec, arc, straight
from softrnn.rod.discrete import internal_loads, segment_strains, strain_energy
from softrnn.rod.so3 import cay

from helpers import fd_loads_of, kernel_internal_loads, kernel_step, planar_bent_shape, random_deformed_rod

GRADIENT_RTOL = 1e-6      # central finite differences vs closed-form loads (relative to max |load|)
KERNEL_RTOL = 1e-10       # numba kernel loads vs discrete.internal_loads (relative to max |load|)
EXACT_TOL = 1e-12         # closed-form strains of exact shapes
FD_STEP = 1e-6


def fd_loads(R, r, l, C1, C2, K0, G0, eps=FD_STEP):
    """-dU/dr_a (world) and -dU/d eps (body) of the strain energy, central differences."""
    return fd_loads_of(lambda RR, rr: strain_energy(RR, rr, l, C1, C2, K0, G0), R, r, eps)


def rel_err(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("n", [2, 3, 7])
def test_internal_loads_are_minus_energy_gradient(seed, n):
    rng = np.random.default_rng(seed)
    l = 0.1
    R, r, K0, G0, C1, C2 = random_deformed_rod(rng, n, l)
    f, t = internal_loads(R, r, l, C1, C2, K0, G0)
    f_fd, t_fd = fd_loads(R, r, l, C1, C2, K0, G0)
    assert np.abs(f).max() > 0.1 and np.abs(t).max() > 0.01  # a loaded configuration
    assert rel_err(f, f_fd) < GRADIENT_RTOL
    assert rel_err(t, t_fd) < GRADIENT_RTOL


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("n", [2, 3, 9])
def test_kernel_loads_match_discrete_loads(seed, n):
    rng = np.random.default_rng(100 + seed)
    l = 0.1
    R, r, K0, G0, C1, C2 = random_deformed_rod(rng, n, l)
    f, t = internal_loads(R, r, l, C1, C2, K0, G0)
    fk, tk, ek = kernel_internal_loads(R, r, l=l, C1=C1, C2=C2, K0=K0, G0=G0)
    assert rel_err(fk, f) < KERNEL_RTOL
    assert rel_err(tk, t) < KERNEL_RTOL
    assert ek == pytest.approx(strain_energy(R, r, l, C1, C2, K0, G0), rel=1e-12)


def test_kernel_gravitational_energy():
    """out_e[:, 2] = -sum m g.r at the start of the step."""
    rng = np.random.default_rng(7)
    n, l = 5, 0.1
    R, r, K0, G0, C1, C2 = random_deformed_rod(rng, n, l)
    mass = rng.uniform(0.5, 2.0, n)
    g = np.array([0.3, -1.0, -9.81])
    expected = -np.sum(mass * (r @ g))
    _, _, out = kernel_step(R.copy(), r.copy(), np.zeros((n, 3)), np.zeros((n, 3)), l=l, C1=C1, C2=C2, K0=K0,
                            G0=G0, mass=mass, inertia=np.ones((n, 3)), h=1e-4, gravity=g)
    assert out["e"][0, 2] == pytest.approx(expected, rel=1e-13)


def test_internal_loads_are_self_equilibrated():
    """Sum f = 0 and sum (r x f + Lambda t) = 0: the energy is invariant under rigid motions."""
    rng = np.random.default_rng(3)
    l = 0.1
    R, r, K0, G0, C1, C2 = random_deformed_rod(rng, 8, l)
    f, t = internal_loads(R, r, l, C1, C2, K0, G0)
    scale = np.abs(f).max() * np.abs(r).max() + np.abs(t).max()
    assert np.abs(f.sum(0)).max() < 1e-13 * np.abs(f).max()
    moment = np.sum(np.cross(r, f) + np.einsum("aij,aj->ai", R, t), axis=0)
    assert np.abs(moment).max() < 1e-13 * scale


def test_strains_and_loads_are_frame_indifferent():
    rng = np.random.default_rng(4)
    l = 0.1
    R, r, K0, G0, C1, C2 = random_deformed_rod(rng, 6, l)
    Qr = cay(np.array([0.4, -1.2, 0.7]))
    shift = np.array([0.3, -0.1, 2.0])
    R2 = Qr @ R
    r2 = r @ Qr.T + shift
    K, G = segment_strains(R, r, l)
    K2, G2 = segment_strains(R2, r2, l)
    np.testing.assert_allclose(K2, K, atol=EXACT_TOL * 10)
    np.testing.assert_allclose(G2, G, atol=EXACT_TOL * 10)
    f, t = internal_loads(R, r, l, C1, C2, K0, G0)
    f2, t2 = internal_loads(R2, r2, l, C1, C2, K0, G0)
    np.testing.assert_allclose(f2, f @ Qr.T, atol=1e-11 * np.abs(f).max())  # world forces rotate
    np.testing.assert_allclose(t2, t, atol=1e-11 * np.abs(t).max())  # body torques do not


def test_straight_rod_strains():
    shape = straight(11, 0.5, direction=(1, 2, -0.5), normal=(0, 0, 1))
    K, G = segment_strains(shape.rotations, shape.positions, 0.05)
    np.testing.assert_allclose(K, 0.0, atol=EXACT_TOL)
    np.testing.assert_allclose(G, np.tile([0.0, 0.0, 1.0], (10, 1)), atol=EXACT_TOL)


@pytest.mark.parametrize("n", [3, 11, 41])
def test_arc_strains_are_shear_free_with_exact_cayley_values(n):
    """A circular arc of radius rho sampled with node angle step dphi: K = (0, 2 tan(dphi/2)/l, 0)
    (d1 points to the centre, d2 is the binormal) and Gamma = (0, 0, tan(dphi/2)/(dphi/2)) exactly;
    no shear (lgvi.md §2.2: the SE(3)-Cayley strain is locking-free)."""
    L, rho = 0.3, 0.3 / np.pi
    shape = arc(n, L, rho, tangent=(0, 1, 0), inward=(1, 0, 0))
    l = L / (n - 1)
    dphi = l / rho
    K, G = segment_strains(shape.rotations, shape.positions, l)
    np.testing.assert_allclose(K[:, [0, 2]], 0.0, atol=EXACT_TOL)
    np.testing.assert_allclose(K[:, 1], 2 * np.tan(dphi / 2) / l, rtol=EXACT_TOL)
    np.testing.assert_allclose(G[:, :2], 0.0, atol=EXACT_TOL)
    np.testing.assert_allclose(G[:, 2], np.tan(dphi / 2) / (dphi / 2), rtol=EXACT_TOL)


def test_planar_bent_shape_helper_is_unstretched_and_shear_free():
    angles = np.linspace(0, 1.0, 15) ** 2
    shape = planar_bent_shape(angles, 0.02)
    K, G = segment_strains(shape.rotations, shape.positions, 0.02)
    np.testing.assert_allclose(G, np.tile([0.0, 0.0, 1.0], (14, 1)), atol=EXACT_TOL)
    np.testing.assert_allclose(K[:, 1], -2 * np.tan(np.diff(angles) / 2) / 0.02, rtol=EXACT_TOL)


def test_reference_configuration_is_stress_free():
    shape = arc(21, 0.2, 0.2 / np.pi, tangent=(0, 1, 0), inward=(1, 0, 0))
    l = 0.01
    K0, G0 = segment_strains(shape.rotations, shape.positions, l)
    C1 = np.full((20, 3), 10.0)
    C2 = np.full((20, 3), 0.1)
    assert strain_energy(shape.rotations, shape.positions, l, C1, C2, K0, G0) == 0.0
    f, t = internal_loads(shape.rotations, shape.positions, l, C1, C2, K0, G0)
    assert np.abs(f).max() < 1e-12 and np.abs(t).max() < 1e-12


def test_lumped_properties():
    rod = RodSpec(length=0.2, radius=0.01, youngs_modulus=1e7, density=1000, n_nodes=21, poisson_ratio=0.25)
    lump = rod.lumped()
    A, I = np.pi * 0.01**2, np.pi * 0.01**4 / 4
    G = 1e7 / 2.5
    assert lump["mass"].sum() == pytest.approx(1000 * A * 0.2, rel=1e-14)
    assert lump["mass"][0] == pytest.approx(0.5 * lump["mass"][1], rel=1e-14)
    np.testing.assert_allclose(lump["inertia"].sum(0), 1000 * 0.2 * np.array([I, I, 2 * I]), rtol=1e-14)
    np.testing.assert_allclose(lump["C1"], np.tile([G * A, G * A, 1e7 * A], (20, 1)), rtol=1e-14)
    np.testing.assert_allclose(lump["C2"], np.tile([1e7 * I, 1e7 * I, G * 2 * I], (20, 1)), rtol=1e-14)


def test_override_changes_only_its_nodes_and_inner_segments():
    rod = RodSpec(length=0.2, radius=0.01, youngs_modulus=1e7, density=1000, n_nodes=11,
                  overrides=(NodeOverride(first=4, last=6, youngs_modulus=1e9, density=8000),))
    lump = rod.lumped()
    base = RodSpec(length=0.2, radius=0.01, youngs_modulus=1e7, density=1000, n_nodes=11).lumped()
    ratio_m = lump["mass"] / base["mass"]
    np.testing.assert_allclose(ratio_m, [1, 1, 1, 1, 8, 8, 8, 1, 1, 1, 1], rtol=1e-14)
    ratio_E = lump["C1"][:, 2] / base["C1"][:, 2]
    np.testing.assert_allclose(ratio_E, [1, 1, 1, 1, 100, 100, 1, 1, 1, 1], rtol=1e-14)
