"""Helpers shared by the tests: the command line run in-process (``run_cli``), and for the physics
tests direct kernel calls, exact reference solutions, shear-free bent rod shapes and the dynamics
checks shared by the two integrators (convergence order, energy error, zero-crossing period). Imported as
``helpers`` (pytest puts tests/ on sys.path)."""

import contextlib
from dataclasses import dataclass, replace

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from softrnn.io import UNITS, Dataset, write_trajectory
from softrnn.learned.node.data import Normalizer, SampleSpec, make_windows, split
from softrnn.rod import Clamp, RodSpec, RunConfig, Setup, Simulator, Sinusoid, kernels, straight
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


@contextlib.contextmanager
def without_record_builder():
    """No scenario-record builder registered (``softrnn.io.record.set_record_builder``), as where only
    ``softrnn.learned`` is imported: an older data file's record then stays None."""
    from softrnn.io.record import set_record_builder

    previous = set_record_builder(None)
    try:
        yield
    finally:
        set_record_builder(previous)


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


# --------------------------------------------------------------------------- learned node models
def swinging_rod(n_samples: int = 400, n_nodes: int = 5, dt: float = 0.01, *, poison_from: int | None = None,
              freqs=(1.0, 2.3, 1.7, 0.7)) -> Dataset:
    """A smooth, deterministic 'rod': nodes along x swinging in y and z, a sinusoidal force on
    every node (frequencies ``freqs`` in Hz). ``poison_from``: samples from that index on are NaN
    (a test span that must never be read by training)."""
    f1, f2, f3, f4 = freqs
    t = np.arange(n_samples) * dt                                             # (T,)
    k = np.arange(n_nodes)                                                    # (N,)
    pos = np.zeros((n_samples, n_nodes, 3))                                   # (T, N, 3)
    pos[:, :, 0] = 0.1 * k
    pos[:, :, 1] = (0.01 * np.sin(2 * np.pi * f1 * t[:, None] + 0.3 * k)
                    + 0.002 * k * np.sin(2 * np.pi * f2 * t[:, None]))
    pos[:, :, 2] = 0.005 * np.cos(2 * np.pi * f3 * t[:, None] + 0.2 * k)
    quat = np.zeros((n_samples, n_nodes, 4))                                  # (T, N, 4)
    angle = 0.1 * np.sin(2 * np.pi * f1 * t[:, None] + 0.1 * k)
    quat[..., 0], quat[..., 3] = np.cos(angle / 2), np.sin(angle / 2)
    forces = np.zeros((n_samples, n_nodes, 3))                                # (T, N, 3)
    forces[:, :, 1] = 0.1 * np.sin(2 * np.pi * f2 * t)[:, None]
    torques = np.zeros((n_samples, n_nodes, 3))                               # (T, N, 3)
    torques[:, :, 2] = 0.01 * np.cos(2 * np.pi * f4 * t)[:, None]
    if poison_from is not None:
        for arr in (pos, quat, forces, torques):
            arr[poison_from:] = np.nan
    return Dataset(time=t, nodes=k, positions=pos, quaternions=quat, forces=forces, torques=torques,
                   attrs={"dt": dt, "n_nodes_total": n_nodes, "units": {"positions": "m"},
                          "scenario_name": "synthetic"})


N_NODES, DT, LENGTH = 6, 0.01, 0.5


def node_dataset(T: int = 60, n: int = N_NODES, attrs: dict | None = None) -> Dataset:
    """A clamped node 0 and n-1 moving nodes with distinct smooth motions, random wrenches."""
    t = np.arange(T) * DT
    rng = np.random.default_rng(7)
    pos = np.zeros((T, n, 3))
    for a in range(1, n):
        pos[:, a, 0] = LENGTH * a / (n - 1) + 0.01 * np.sin(3.0 * t + a)
        pos[:, a, 1] = 0.02 * a * np.cos(2.0 * t + 0.3 * a)
        pos[:, a, 2] = 0.001 * a * t
    quat = rng.normal(size=(T, n, 4))
    quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
    meta = {"units": dict(UNITS), "rod": {"length": LENGTH, "n_nodes": n}, "n_nodes_total": n, "dt": DT}
    meta.update(attrs or {})
    return Dataset(time=t, nodes=np.arange(n), positions=pos, quaternions=quat,
                   forces=rng.normal(size=(T, n, 3)), torques=rng.normal(size=(T, n, 3)), attrs=meta)


def save_h5(path, ds: Dataset, *, scenario_text: str = "", **attrs):
    write_trajectory(path, ds, dt=DT, rod={"length": LENGTH, "n_nodes": int(ds.attrs["n_nodes_total"])},
                     scenario_text=scenario_text, attrs=attrs)
    return path


class Oracle:
    """A perfect model: looks the next position up in the data from the node's own window."""

    def __init__(self, ds: Dataset, spec: SampleSpec, nodes=None):
        self.spec = spec.resolve(ds.nodes, n_nodes_total=ds.attrs["n_nodes_total"])
        self.meta = {}
        H = self.spec.history
        self.table = {}
        for a in (nodes if nodes is not None else [self.spec.node]):
            col = int(np.flatnonzero(ds.nodes == a)[0])
            for k in range(H, ds.n_samples):
                key = ds.positions[k - H:k, col].tobytes()
                assert self.table.setdefault(key, ds.positions[k, col].tobytes()) == ds.positions[k, col].tobytes()

    def predict(self, poses, wrenches):
        assert poses.dtype == np.float32 and wrenches.shape[:2] == poses.shape[:2]
        return np.array([np.frombuffer(self.table[np.ascontiguousarray(p[:, 0:3]).tobytes()], np.float32)
                         for p in poses], dtype=np.float64)


class Offset:
    """Next position = last position + a fixed step (a model that is always 1 mm off in x)."""

    def __init__(self, spec: SampleSpec, step=(1e-3, 0.0, 0.0)):
        self.spec, self.meta, self.step, self.calls = spec, {}, np.asarray(step), []

    def predict(self, poses, wrenches):
        self.calls.append(poses.shape[0])
        return poses[:, -1, 0:3].astype(np.float64) + self.step


def real_model(ds: Dataset, spec: SampleSpec, meta: dict | None = None) -> "NodeModel":  # noqa: F821
    """An untrained NodeLSTM (fixed seed) with a normaliser fitted on the training span."""
    import torch  # the learn extra: only the tests of learned models call this

    from softrnn.learned.node.artifact import NodeModel
    from softrnn.learned.node.model import ModelConfig, NodeLSTM

    spec = spec.resolve(ds.nodes, n_nodes_total=ds.attrs["n_nodes_total"])
    train = split(ds.n_samples, spec)[0]
    norm = Normalizer.fit(make_windows(ds, spec, train.start, train.stop))
    config = ModelConfig(pose_features=spec.pose_features, wrench_features=spec.wrench_features,
                         history=spec.history, lstm_layers=1, lstm_units=8, dense_units=(8,), wrench_dense=(4,))
    torch.manual_seed(0)
    module = NodeLSTM(config)
    module.set_normalizer(norm)
    module.eval()
    dataset_meta = {"units": dict(UNITS), "n_nodes_total": int(ds.attrs["n_nodes_total"]), "dt": DT,
                    "rod": {"length": LENGTH}, "scenario_name": "synthetic"}
    dataset_meta.update(meta or {})
    return NodeModel(config=config, spec=spec, normalizer=norm, module=module, meta={"dataset": dataset_meta})


# --------------------------------------------------------------------------- whole-manipulator models
def quat_z(angle: np.ndarray) -> np.ndarray:
    """Scalar-first quaternions of rotations by ``angle`` about z: (..., 4)."""
    half = 0.5 * np.asarray(angle, dtype=np.float64)
    return np.stack([np.cos(half), np.zeros_like(half), np.zeros_like(half), np.sin(half)], axis=-1)


def chain_dataset(positions, quaternions, dt, forces=None, torques=None) -> Dataset:
    T, N = positions.shape[:2]
    zeros = np.zeros((T, N, 3))
    return Dataset(time=np.arange(T) * dt, nodes=np.arange(N), positions=positions, quaternions=quaternions,
                   forces=zeros if forces is None else forces, torques=zeros if torques is None else torques,
                   attrs={"dt": dt, "rod": {"length": LENGTH, "n_nodes": N}})


def bending_chain(amp: float, phase: float, *, n_nodes: int = 11, n_samples: int = 241, dt: float = 0.005) -> Dataset:
    """A damped two-mode bending oscillation of a cantilever chain in the x-y plane (node 0 clamped),
    orientations following the slope: what a linear second-order model fits and a long free run
    with no load must not blow up from."""
    t = np.arange(n_samples) * dt
    s = np.linspace(0.0, 1.0, n_nodes)
    w1, z1, w2, z2 = 2 * np.pi * 2.0, 0.08, 2 * np.pi * 5.0, 0.1
    m1 = amp * np.exp(-z1 * w1 * t) * np.cos(w1 * np.sqrt(1 - z1 ** 2) * t + phase)
    m2 = 0.3 * amp * np.exp(-z2 * w2 * t) * np.cos(w2 * np.sqrt(1 - z2 ** 2) * t + 2 * phase)
    y = m1[:, None] * s ** 2 + m2[:, None] * s ** 2 * (s - 0.7)
    slope = (m1[:, None] * 2 * s + m2[:, None] * (3 * s ** 2 - 1.4 * s)) / LENGTH
    pos = np.stack([np.broadcast_to(s * LENGTH, y.shape), y, np.zeros_like(y)], axis=-1)
    return chain_dataset(pos, quat_z(np.arctan(slope)), dt)


# --------------------------------------------------------------------------- robot recordings
def tendon_robot_truth(n_segments: int = 1):
    """A known displacement-driven tendon robot (``softrnn.lab.tendon_robot``): segments of 0.08 m,
    three tendons each at 4 mm, the segments' tendons turned by 40 deg from each other, pointing
    up from (0, 0, 0.01) m with a 5 mm marker offset."""
    from softrnn.lab.tendon_robot import TendonParameters, TendonRobot

    robot = TendonRobot(tuple([0.08] * n_segments), 3, 4e-3)
    angles = np.radians(np.tile([0.0, 120.0, 240.0], n_segments) + np.repeat(np.arange(n_segments) * 40.0, 3))
    params = TendonParameters(angles=angles, offsets=np.full(3 * n_segments, -0.5e-3), routing_radius=4e-3,
                              compliance=np.full(n_segments, 1.0 / (4e-3 ** 2 * 0.08)), marker=5e-3,
                              rotation=np.zeros(3), base=np.array([0.0, 0.0, 0.01]))
    return robot, params


def tendon_recording(path, rows: int = 120, *, seed: int = 0, n_segments: int = 1, noise_mm: float = 0.1,
                     lag: int = 0, scale_mm: float = 3.0, header=None):
    """Write a synthetic stand-in of a real robot's recording (the layout of a motion-capture
    session: ``timestamp`` in Unix time with irregular steps and one long pause, ``pattern_label``,
    ``servo_<id>_mm`` commands, ``tip_x, tip_y, tip_z`` in mm) from ``tendon_robot_truth``, the tip
    lagging the command by ``lag`` rows; returns (time (T,), commands (T, m) [mm], tip (T, 3) [mm])."""
    from softrnn.lab.tendon_robot import tip_positions

    robot, params = tendon_robot_truth(n_segments)
    rng = np.random.default_rng(seed)
    m = robot.n_tendons
    # smooth random pulls in turn, some tendons released (negative)
    phase = rng.uniform(0, 2 * np.pi, m)
    k = np.arange(rows)
    u = scale_mm * np.sin(0.07 * k[:, None] * (1 + 0.3 * np.arange(m)) + phase) - 0.5
    tip = tip_positions(robot, params, u * 1e-3)[0] * 1e3
    tip = np.vstack([np.repeat(tip[:1], lag, axis=0), tip[:rows - lag]]) + rng.normal(0, noise_mm, (rows, 3))
    steps = rng.uniform(0.52, 0.69, rows - 1)
    steps[rows // 2] = 20.0
    time = 1775513850.298145 + np.concatenate([[0.0], np.cumsum(steps)])
    ids = [1, 20, 23, 9, 6, 11, 24, 2, 3][:m] if m <= 9 else list(range(m))
    names = header or (["timestamp", "pattern_label"] + [f"servo_{i}_mm" for i in ids] + ["tip_x", "tip_y", "tip_z"])
    lines = [",".join(names)]
    for r in range(rows):
        lines.append(",".join([f"{time[r]:.6f}", f"pattern_{r // 20}"] + [f"{x:.6f}" for x in u[r]]
                              + [f"{x:.6f}" for x in tip[r]]))
    path.write_text("\n".join(lines) + "\n")
    return time, u, tip


# --------------------------------------------------------------------------- dynamics checks
ORDER_RANGE = (1.8, 2.2)         # measured convergence order in h


def zero_crossing_period(t, z):
    """Period from linearly interpolated zero crossings (least-squares slope of crossing times)."""
    s = np.sign(z)
    idx = np.nonzero(s[:-1] * s[1:] < 0)[0]
    tc = t[idx] - z[idx] * (t[idx + 1] - t[idx]) / (z[idx + 1] - z[idx])
    return 2.0 * np.polyfit(np.arange(tc.size), tc, 1)[0], tc.size


def gravity_release(n=15, L=0.2, r=0.005, E=1e6):
    """Horizontal cantilever released in gravity: swings down to ~0.9 L below the clamp."""
    rod = RodSpec(length=L, radius=r, youngs_modulus=E, density=1000, n_nodes=n)
    return Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                 gravity=(0, 0, -9.81))


def energy_error(sim, steps, h, integrator="explicit"):
    traj = sim.run(RunConfig(dt=100 * h, n_samples=steps // 100 + 1, substeps=100, integrator=integrator))
    assert traj.n_steps == steps
    total = traj.energy.sum(axis=1)
    exchanged = np.ptp(traj.energy[:, 2])
    return (total - total[0]) / exchanged, traj


def smooth_ramp(value, frequency):
    """value * (1 - cos(2 pi f t)) / 2: zero value and zero slope at t = 0."""
    v = np.asarray(value, float)
    return Sinusoid(tuple(v / 2), frequency, -np.pi / 2, tuple(v / 2))


def convergence_order(setup, dt=0.025, n_samples=21, levels=(1, 2, 4, 8), ref=64, integrator="explicit", base=None):
    base = base or int(np.ceil(dt / Simulator(setup).stable_step()))
    runs = {m: Simulator(setup).run(RunConfig(dt=dt, n_samples=n_samples, substeps=base * m,
                                              integrator=integrator)).positions
            for m in (*levels, ref)}
    h = np.array([dt / (base * m) for m in levels])
    err = np.array([np.abs(runs[m] - runs[ref]).max() for m in levels])
    return np.polyfit(np.log(h), np.log(err), 1)[0], err


@dataclass(frozen=True, eq=False)
class Drifting:
    """A lab model (``softrnn.lab``'s fit/predict/reach protocol) exact on the commands it was fitted on
    and wrong by ``c`` [m] per standard deviation of the distance from them (along y), its first input
    read as the tip's x [mm]: a learned model extrapolating."""

    c: float = 1e-3
    reach: object = None
    name: str = "drifting"

    def fit(self, sessions):
        from softrnn.lab.uncertainty import InputDistance

        return replace(self, reach=InputDistance.of(sessions))

    def predict(self, s):
        return np.column_stack([s.inputs[:, 0] * 1e-3, self.c * self.reach(s), np.zeros(s.n_rows)])

    def describe(self):
        return {"kind": "drifting"}


@dataclass(frozen=True, eq=False)
class Recalling:
    """A model that recalls the tip of every row it was fitted on (an overfitted network, a sequence
    model that learnt its session by heart) and elsewhere gives the mean tip of the fitted rows with the
    nearest command."""

    seen: dict | None = None
    levels: np.ndarray | None = None
    means: np.ndarray | None = None
    reach: object = None
    name: str = "recalling"

    def fit(self, sessions):
        from softrnn.lab.uncertainty import InputDistance

        u, tips = np.concatenate([s.inputs[:, 0] for s in sessions]), np.vstack([s.tip for s in sessions])
        levels = np.unique(u)
        return replace(self, seen={(s.path, t): tip for s in sessions for t, tip in zip(s.time, s.tip)},
                       levels=levels, means=np.array([tips[u == v].mean(axis=0) for v in levels]),
                       reach=InputDistance.of(sessions))

    def predict(self, s):
        nearest = self.means[np.abs(s.inputs[:, :1] - self.levels[None]).argmin(axis=1)]
        return np.array([self.seen.get((s.path, t), m) for t, m in zip(s.time, nearest)])

    def describe(self):
        return {"kind": "recalling"}
