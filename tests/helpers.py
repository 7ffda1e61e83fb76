"""Helpers shared by the tests: the command line run in-process (``run_cli``), and for the physics
tests direct kernel calls, exact reference solutions and shear-free bent rod shapes. Imported as
``helpers`` (pytest puts tests/ on sys.path)."""

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from softrnn.rod import kernels
from softrnn.rod.lumped import frozen
from softrnn.rod.shapes import RodShape
from softrnn.rod.so3 import axis_rotation, cay, frame_from_tangent
from softrnn.rod.state import empty_samples


# --------------------------------------------------------------------------- command line
def run_cli(argv) -> int:
    """``softrnn ARGV`` in this process (``softrnn.cli.main.main``): its exit code, also when argparse
    exits (2 for a usage error)."""
    from softrnn.cli.main import main

    try:
        return main(argv)
    except SystemExit as exc:  # argparse errors
        return exc.code


# --------------------------------------------------------------------------- finite differences
def fd_loads_of(U, R, r, eps):
    """-dU/dr_a (world) and -dU/d eps with Lambda_a -> Lambda_a cay(eps e_i) (body) of an energy
    U(R (n, 3, 3), r (n, 3)), central differences: the loads (n, 3), (n, 3) it exerts on each node."""
    n = r.shape[0]
    f = np.zeros((n, 3))
    t = np.zeros((n, 3))
    for a in range(n):
        for i in range(3):
            e = np.zeros(3)
            e[i] = eps
            rp, rm = r.copy(), r.copy()
            rp[a] += e
            rm[a] -= e
            f[a, i] = -(U(R, rp) - U(R, rm)) / (2 * eps)
            Rp, Rm = R.copy(), R.copy()
            Rp[a] = R[a] @ cay(e)
            Rm[a] = R[a] @ cay(-e)
            t[a, i] = -(U(Rp, r) - U(Rm, r)) / (2 * eps)
    return f, t


# --------------------------------------------------------------------------- kernel access
def kernel_step(R, r, v, w, *, l, C1, C2, K0, G0, mass, inertia, h, n_steps=1, kind=None,
                gravity=(0.0, 0.0, 0.0), ct=None, cr=None):
    """Advance (in place) ``n_steps`` steps of size h with kernels.advance: no loads, no
    Kelvin-Voigt damping, every node saved at every step. Returns (status, step, out dict)."""
    n = r.shape[0]
    zeros_seg = np.zeros((n - 1, 3))
    rod = frozen(length=l, weight=np.ones(n), mass=mass, inertia=inertia, C1=C1, C2=C2, D1=zeros_seg, D2=zeros_seg,
                 K0=K0, G0=G0, ct=np.zeros(n) if ct is None else ct, cr=np.zeros(n) if cr is None else cr,
                 gravity=gravity, kind=np.zeros(n) if kind is None else kind, kv_on=False)
    state = kernels.StateArrays(R, r, v, w, np.zeros((n - 1, 3)), np.zeros((n - 1, 3)))
    none = np.zeros(0, np.int64)
    inputs = kernels.StepInputs(none, np.zeros((n_steps, 0, 12)), none, np.zeros((n_steps, 0, 3)), np.zeros((0, 2)),
                                none, np.zeros((n_steps + 1, 0, 3)), np.zeros((n_steps + 1, 0, 3, 3)))
    samples = empty_samples(np.arange(n, dtype=np.int64), n_steps, n)
    code, step = kernels.advance(rod, state, inputs, samples, float(h), 0, int(n_steps), 1, 0)
    out = {"r": samples.positions, "q": samples.quaternions, "v": samples.velocities,
           "w": samples.angular_velocities, "f": samples.forces, "t": samples.torques,
           "rf": samples.reaction_forces, "rt": samples.reaction_torques, "e": samples.energy}
    return int(code), int(step), out


def kernel_internal_loads(R, r, *, l, C1, C2, K0, G0, h=1e-4):
    """Internal loads as the kernel applies them: one step from rest of free, unit-mass,
    unit-inertia nodes without gravity or damping. f = m v^0 / h (world); the body torque t solves
    J y + y x J y / 2 + (y.Jy) y / 4 = h^2 t with y = h omega^0. Also returns the kernel's strain
    energy of the initial configuration."""
    n = r.shape[0]
    R = np.array(R, dtype=float)
    r = np.array(r, dtype=float)
    v = np.zeros((n, 3))
    w = np.zeros((n, 3))
    mass = np.ones(n)
    inertia = np.ones((n, 3))
    code, _, out = kernel_step(R, r, v, w, l=l, C1=C1, C2=C2, K0=K0, G0=G0, mass=mass, inertia=inertia, h=h)
    assert code == kernels.OK
    f = mass[:, None] * v / h
    y = h * w
    Jy = inertia * y
    t = (Jy + 0.5 * np.cross(y, Jy) + 0.25 * np.sum(y * Jy, 1, keepdims=True) * y) / h**2
    return f, t, out["e"][0, 1]


# --------------------------------------------------------------------------- shapes
def planar_bent_shape(angles, seg_length):
    """Rod in the xz-plane starting at the origin along +x (frames of
    ``straight(direction=(1, 0, 0), normal=(0, 0, 1))``), node a turned by ``angles[a]`` about +y
    (positive angles bend it toward -z). Chords are placed at the mean angle of their two nodes with
    length l cos(dtheta/2), which makes the SE(3)-Cayley strains exactly Gamma = e3 (no shear, no
    stretch) and K = (0, -2 tan(dtheta/2)/l, 0)."""
    angles = np.asarray(angles, dtype=float)
    n = angles.size
    base = frame_from_tangent(np.array([1.0, 0, 0]), np.array([0, 0, 1.0]))
    Ry = axis_rotation("y", angles)
    R = Ry @ base
    mid = 0.5 * (angles[1:] + angles[:-1])
    dth = np.diff(angles)
    chord = seg_length * np.cos(0.5 * dth)[:, None] * np.stack([np.cos(mid), np.zeros(n - 1), -np.sin(mid)], -1)
    pos = np.concatenate([np.zeros((1, 3)), np.cumsum(chord, axis=0)])
    return RodShape(pos, R)


def random_deformed_rod(rng, n, l, *, rot_scale=0.3, pos_scale=0.2):
    """A random, strongly deformed configuration (n nodes, segment length l) and random
    stress-free strains K0, G0 and stiffnesses C1, C2 of different magnitudes per segment."""
    R = np.empty((n, 3, 3))
    r = np.empty((n, 3))
    R[0] = cay(rng.normal(size=3))
    r[0] = rng.normal(size=3) * l
    for a in range(1, n):
        R[a] = R[a - 1] @ cay(rot_scale * rng.normal(size=3))
        r[a] = r[a - 1] + R[a - 1] @ (l * (np.array([0, 0, 1.0]) + pos_scale * rng.normal(size=3)))
    K0 = rng.normal(size=(n - 1, 3)) * 2.0
    G0 = np.array([0, 0, 1.0]) + 0.1 * rng.normal(size=(n - 1, 3))
    C1 = rng.uniform(1.0, 10.0, size=(n - 1, 3)) * [1.0, 1.0, 5.0]
    C2 = rng.uniform(0.05, 0.5, size=(n - 1, 3))
    return R, r, K0, G0, C1, C2


# --------------------------------------------------------------------------- exact statics
def reissner_cantilever_tip(P, L, EI, EA=np.inf, GAk=np.inf):
    """Tip position (x, z) of a planar Reissner (extensible, shearable) cantilever clamped at the
    origin along +x and loaded at its free end by the dead force (0, -P) [N]; EA = GAk = inf gives
    the inextensible, unshearable Euler elastica. Solved by shooting on the root moment.

    Sign convention (xz-plane): th > 0 turns the tangent d3 = (cos th, -sin th) toward -z, i.e. a
    rotation about +y; d1 = (sin th, cos th). The internal force is n = (0, -P) along the whole rod;
    strains N/EA = n.d3/EA and V/GAk = n.d1/GAk give r' = (1 + N/EA) d3 + (V/GAk) d1; the bending
    moment about +y is m = EI th' with m' = -(r' x n)_y and m(L) = 0.
    """
    n = np.array([0.0, -P])

    def rhs(s, y):
        th, m = y[0], y[1]
        d3 = np.array([np.cos(th), -np.sin(th)])
        d1 = np.array([np.sin(th), np.cos(th)])
        N = n @ d3
        V = n @ d1
        rp = (1.0 + N / EA) * d3 + (V / GAk) * d1
        # moment about +y (bending toward -z is positive th): m' = -(r' x n)_y, with
        # (a x b)_y = a_z b_x - a_x b_z for a = (a_x, a_z)
        cross_y = rp[1] * n[0] - rp[0] * n[1]
        return [m / EI, -cross_y, rp[0], rp[1]]

    def end_moment(m0):
        with np.errstate(under="ignore"):  # solve_ivp's step-size control underflows harmlessly
            sol = solve_ivp(rhs, (0.0, L), [0.0, m0, 0.0, 0.0], rtol=1e-12, atol=1e-14, method="DOP853")
        return sol.y[1, -1], sol.y[:, -1]

    # the root moment is between 0 and P L (a straight lever arm bounds it)
    m0 = brentq(lambda m: end_moment(m)[0], 0.0, P * L * 1.0001, xtol=1e-15 * P * L, rtol=1e-14)
    y = end_moment(m0)[1]
    return y[2], y[3]
