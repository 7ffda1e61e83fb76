"""Rotation helpers (Cayley map, its tangent, quaternions) and orthogonality of the integrator's
rotations over long runs (lgvi.md §2.2, §2.10 item 1, §2.8)."""

import numpy as np
import pytest
from scipy.linalg import expm

from softrnn.rod import Clamp, Constant, NodalLoad, RodSpec, RunConfig, Setup, Simulator, Sinusoid, Window, straight
from softrnn.rod.so3 import (
    axis_rotation,
    cay,
    cay_inv,
    dcay_inv,
    frame_from_tangent,
    hat,
    matrix_to_quaternion,
    quaternion_to_matrix,
)

IDENTITY_TOL = 1e-12          # algebraic identities on O(1) quantities
FD_TOL = 1e-8                 # finite-difference derivative checks (central, step 1e-6)
ORTHO_TOL_LONG_RUN = 1e-12    # max |R^T R - I| after 1e5 solver steps


def random_vectors(rng, count, scale):
    """Random Cayley vectors with magnitudes spread over [0, scale]."""
    d = rng.normal(size=(count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return d * rng.uniform(0.0, scale, size=(count, 1))


def random_rotations(rng, count):
    q = rng.normal(size=(count, 4))
    return quaternion_to_matrix(q / np.linalg.norm(q, axis=1, keepdims=True))


@pytest.fixture
def rng():
    return np.random.default_rng(20240521)


def test_hat_is_the_cross_product(rng):
    x, y = rng.normal(size=(2, 50, 3))
    np.testing.assert_allclose(np.einsum("aij,aj->ai", hat(x), y), np.cross(x, y), atol=IDENTITY_TOL)
    np.testing.assert_allclose(hat(x), -np.swapaxes(hat(x), 1, 2), atol=0)


@pytest.mark.parametrize("scale", [1e-6, 0.1, 1.0, 10.0])
def test_cay_is_a_proper_rotation(rng, scale):
    Q = cay(random_vectors(rng, 200, scale))
    err = np.abs(np.swapaxes(Q, 1, 2) @ Q - np.eye(3)).max()
    assert err < IDENTITY_TOL
    np.testing.assert_allclose(np.linalg.det(Q), 1.0, atol=IDENTITY_TOL)


@pytest.mark.parametrize("scale", [1e-6, 0.1, 1.0, 10.0])
def test_cay_inv_inverts_cay(rng, scale):
    x = random_vectors(rng, 200, scale)
    # relative to |x| (cay_inv loses digits like 1/(1 + tr Q) near angle pi, i.e. |x| large)
    err = np.linalg.norm(cay_inv(cay(x)) - x, axis=1) / np.maximum(1.0, np.linalg.norm(x, axis=1) ** 2)
    assert err.max() < IDENTITY_TOL


def test_cay_of_cay_inv_on_random_rotations(rng):
    R = random_rotations(rng, 200)
    angle = np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1))
    R = R[angle < 0.95 * np.pi]  # cay_inv is defined for rotation angles below pi
    np.testing.assert_allclose(cay(cay_inv(R)), R, atol=1e-10)


def test_cay_rotation_angle_and_axis(rng):
    x = random_vectors(rng, 200, 20.0)
    Q = cay(x)
    angle = np.arccos(np.clip((np.trace(Q, axis1=1, axis2=2) - 1) / 2, -1, 1))
    np.testing.assert_allclose(angle, 2 * np.arctan(np.linalg.norm(x, axis=1) / 2), atol=1e-7)
    # the axis is x itself: Q x = x
    np.testing.assert_allclose(np.einsum("aij,aj->ai", Q, x), x, atol=IDENTITY_TOL * 100)
    # and it agrees with the explicit rotation about a coordinate axis
    for axis, e in (("x", 0), ("y", 1), ("z", 2)):
        v = np.zeros(3)
        v[e] = 0.7
        np.testing.assert_allclose(cay(v), axis_rotation(axis, 2 * np.arctan(0.35)), atol=IDENTITY_TOL)


def test_cay_matches_exp_to_second_order():
    # cay(x) = exp(x^) + O(|x|^3): halving x divides the difference by 8
    x = np.array([0.3, -0.2, 0.5])
    d1 = np.abs(cay(x) - expm(hat(x))).max()
    d2 = np.abs(cay(x / 2) - expm(hat(x / 2))).max()
    assert 7.0 < d1 / d2 < 9.0


@pytest.mark.parametrize("scale", [0.1, 1.0, 3.0])
def test_dcay_inv_is_the_inverse_right_trivialised_tangent(rng, scale):
    """d/de cay(x + e dx) cay(x)^T = hat(dcay(x) dx), and dcay_inv(x) = dcay(x)^-1."""
    eps = 1e-6
    for x in random_vectors(rng, 20, scale):
        Qt = cay(x).T
        for dx in np.eye(3):
            D = (cay(x + eps * dx) - cay(x - eps * dx)) / (2 * eps) @ Qt
            np.testing.assert_allclose(D, -D.T, atol=FD_TOL)  # a skew matrix
            w = np.array([D[2, 1], D[0, 2], D[1, 0]])
            np.testing.assert_allclose(dcay_inv(x) @ w, dx, atol=FD_TOL)
    # closed form of dcay: 4/(4 + |x|^2) (I + x^/2)
    x = random_vectors(rng, 50, scale)
    dcay = 4.0 / (4.0 + np.sum(x * x, 1))[:, None, None] * (np.eye(3) + 0.5 * hat(x))
    np.testing.assert_allclose(dcay @ dcay_inv(x), np.broadcast_to(np.eye(3), dcay.shape), atol=IDENTITY_TOL)


@pytest.mark.parametrize("scale", [0.1, 1.0, 10.0])
def test_cay_transpose_identity(rng, scale):
    """cay(x)^T dcay_inv(x)^T = dcay_inv(-x)^T (lgvi.md §2.2)."""
    x = random_vectors(rng, 100, scale)
    lhs = np.swapaxes(cay(x), 1, 2) @ np.swapaxes(dcay_inv(x), 1, 2)
    rhs = np.swapaxes(dcay_inv(-x), 1, 2)
    np.testing.assert_allclose(lhs, rhs, atol=IDENTITY_TOL * max(1.0, scale**2))


def test_dcay_inv_transpose_action(rng):
    """dcay_inv(x)^T y = y + x × y / 2 + x (x.y) / 4 (the form the kernel uses)."""
    x, y = rng.normal(size=(2, 50, 3))
    lhs = np.einsum("aji,aj->ai", dcay_inv(x), y)
    rhs = y + 0.5 * np.cross(x, y) + 0.25 * x * np.sum(x * y, 1, keepdims=True)
    np.testing.assert_allclose(lhs, rhs, atol=IDENTITY_TOL * 10)


def test_quaternion_round_trips(rng):
    q = rng.normal(size=(500, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    R = quaternion_to_matrix(q)
    assert np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max() < IDENTITY_TOL
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=IDENTITY_TOL)
    q2 = matrix_to_quaternion(R)
    assert np.all(q2[:, 0] >= 0)
    np.testing.assert_allclose(q2, q * np.sign(q[:, :1]), atol=1e-12)
    np.testing.assert_allclose(quaternion_to_matrix(q2), R, atol=IDENTITY_TOL)


def test_quaternion_round_trip_near_half_turns():
    """Angles near pi exercise every branch of the matrix -> quaternion conversion."""
    rows = []
    for axis in ("x", "y", "z"):
        for angle in (np.pi, np.pi - 1e-9, -np.pi + 1e-3, 0.0, 1e-12):
            rows.append(axis_rotation(axis, angle))
    R = np.array(rows) @ axis_rotation("x", 1e-7)  # break exact symmetry a little
    q = matrix_to_quaternion(R)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=IDENTITY_TOL)
    np.testing.assert_allclose(quaternion_to_matrix(q), R, atol=1e-12)


def test_quaternion_convention_scalar_first_body_to_world():
    theta = 0.8
    q = matrix_to_quaternion(axis_rotation("z", theta))
    np.testing.assert_allclose(q, [np.cos(theta / 2), 0, 0, np.sin(theta / 2)], atol=IDENTITY_TOL)
    np.testing.assert_allclose(quaternion_to_matrix(q) @ [1, 0, 0], [np.cos(theta), np.sin(theta), 0],
                               atol=IDENTITY_TOL)


def test_frame_from_tangent_is_right_handed(rng):
    t, n = rng.normal(size=(2, 100, 3))
    F = frame_from_tangent(t, n)
    assert np.abs(np.swapaxes(F, 1, 2) @ F - np.eye(3)).max() < IDENTITY_TOL
    np.testing.assert_allclose(np.linalg.det(F), 1.0, atol=IDENTITY_TOL)
    np.testing.assert_allclose(F[:, :, 2], t / np.linalg.norm(t, axis=1, keepdims=True), atol=IDENTITY_TOL)
    assert np.all(np.sum(F[:, :, 0] * n, axis=1) > 0)  # d1 along the hint


# --------------------------------------------------------------------------- integrator
def _tumbling_setup(case):
    n, L = 8, 0.2
    rod = RodSpec(length=L, radius=0.01, youngs_modulus=1e6, density=1000, n_nodes=n, poisson_ratio=0.4)
    shape = straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1))
    if case == "free":
        # a short kick (force + body torque about a non-principal axis) then free tumbling
        loads = (NodalLoad(0, torque=Window(Constant((2e-3, -1e-3, 3e-3)), 0.0, 0.02), frame="body"),
                 NodalLoad(-1, force=Window(Constant((0.0, 0.05, 0.2)), 0.0, 0.02)))
        return Setup(rod=rod, reference=shape, loads=loads)
    # cantilever driven by an oscillating bending + twisting tip torque
    loads = (NodalLoad(-1, torque=Sinusoid((2.5e-2, 1.5e-2, 1e-2), 1.0), frame="body"),)
    return Setup(rod=rod, reference=shape, boundary=(Clamp(0),), loads=loads)


@pytest.mark.parametrize("case", ["free", "cantilever"])
def test_rotations_stay_orthogonal_over_1e5_steps(case):
    sim = Simulator(_tumbling_setup(case))
    h = sim.stable_step()
    steps = 100_000
    traj = sim.run(RunConfig(dt=h * 1000, n_samples=steps // 1000 + 1, substeps=1000))
    assert traj.n_steps == steps
    R = sim.state.rotations
    err = np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max()
    assert err < ORTHO_TOL_LONG_RUN, err
    # the motion must be substantial for the test to mean anything: the end frames turned a lot
    q = traj.quaternions[:, -1]
    turned = 2 * np.degrees(np.arccos(np.clip(np.abs(np.sum(q[1:] * q[0], 1)), 0, 1)))
    assert turned.max() > 30.0
    assert np.all(np.isfinite(traj.positions))
