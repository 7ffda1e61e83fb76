"""The paper's magnetic experiment, simulated (Tariverdi et al. 2021, section 5, Table 1, Fig. 12).

The dynamic Cosserat model of ``softrnn.magnetics`` plays the real robot, with parameters a few
percent off the nominal ones (``ExperimentConfig``: stiffer rubber, weaker magnets, more damping),
driven by smooth random coil currents. A camera-like measurement samples its centreline, adds
pixel-level noise, fits a polynomial P(s) per coordinate and reads each magnet's orientation from
the fit's tangent at the magnet (paper section 5.2):

    phi_m = acos(z . unit(dP/ds(s_m))),   k_m = unit(z x dP/ds(s_m)),

reported as the rotation vector phi_m k_m [deg] (the rotation taking z to the tangent), whose x, y
and z components are the orientations "about x, y and z" of Table 1. The motion is mostly in the
vertical xz-plane, so the large angle is about y, the bending axis; k_m is perpendicular to z by
construction, so the z component is identically zero (``ORIENTATION_NOTE``).

Two models predict the measured orientations of the last 40 % of the samples:

* the static Cosserat model (``softrnn.statics``) with the nominal parameters, from the coil currents
  alone (``static_predictions``: B and G at the magnets by fixed-point iteration on their positions);
* one LSTM per magnet (paper Fig. 11; ``softrnn.surrogate``): input I the measured orientations of
  both magnets, input II the magnet's wrench [f, tau] computed, as the paper did, from the measured
  magnet pose, the nominal magnet moment and the currents; history 2; trained on the first 60 %;
  evaluated one step ahead (as Table 1) and free running.

``run_experiment`` writes the real robot's record (``robot.h5``, resumable), the two model folders,
``table1.json`` and ``fig12.png`` and returns the report (errors as [[max, mean] per axis x, y, z]
in degrees beside the paper's). ``compare`` is the comparison alone, shared with lab data
(``softrnn.experiments.magnetic.lab``).

Progress: ``progress(stage, done, total)`` with stage one of ``STAGES``.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from ... import __version__
from ...errors import SimulationError, SoftrnnInputError, bad
from ...magnetics.coils import unit_field_maps
from ...magnetics.magnets import wrench as magnet_wrench
from ...magnetics.manipulator import CurrentSchedule, ManipulatorRun, ManipulatorSpec, check_manipulator_run, simulate_manipulator

MAGNETS = ("proximal", "distal")
"""Magnet names in index order (0 at L/2, 1 at the tip; the paper's m = 1, 2 from the base)."""

AXES = ("x", "y", "z")

STAGES = ("simulate", "camera", "static", "train proximal", "train distal", "evaluate")

QUICK_SAMPLES = 240
QUICK_EPOCHS = 8
FULL_SAMPLES = 669
FULL_EPOCHS = 25

ROBOT_FILE = "robot.h5"
TABLE_FILE = "table1.json"
FIGURE_FILE = "fig12.png"
MODELS_DIR = "models"

ORIENTATION_NOTE = (
    "orientation = rotation vector phi_m k_m in degrees, phi_m = acos(z . t), k_m = unit(z x t), t = "
    "unit(dP/ds(s_m)) the fitted centreline's tangent at the magnet (paper section 5.2): the rotation "
    "taking z to the tangent. 'About x, y, z' are its components. The motion is mostly in the vertical "
    "xz-plane, so the bending axis is y (the large angle, about 90 deg at rest); x follows the small "
    "out-of-plane swing; k_m is perpendicular to z by construction, so the z component is identically "
    "zero in every measurement and static prediction (their z errors are 0; the LSTM learns the constant "
    "to within ~0.01 deg). The paper reports nonzero z errors, so it cannot have used exactly this "
    "definition; tangent_angles gives the errors of the tangent's elevation (about y) and heading (about "
    "z) as a check on the out-of-plane motion.")


def _is_int(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def _number(name: str, value, *, low: float | None = None, high: float | None = None, positive: bool = False,
            unit: str = "") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or (positive and value <= 0) or (low is not None and value < low) \
            or (high is not None and value > high):
        rng = " > 0" if positive else ""
        if low is not None or high is not None:
            rng = f" in [{'-inf' if low is None else f'{low:g}'}, {'inf' if high is None else f'{high:g}'}]"
        raise bad(name, value, f"a finite number{rng}{' ' + unit if unit else ''}")
    return float(value)


def _integer(name: str, value, low: int) -> int:
    if not _is_int(value) or value < low:
        raise bad(name, value, f"an integer >= {low}")
    return int(value)


# ------------------------------------------------------------------------------------------ config
@dataclass(frozen=True, kw_only=True)
class ExperimentConfig:
    """The simulated experiment (defaults: the paper's 669 samples, history 2, 60 % training).

    Parameters
    ----------
    samples : int or None
        Measured samples (None: 669, or ``QUICK_SAMPLES`` = 240 with ``quick``).
    sample_rate : float
        Camera frame rate [Hz] (not given in the paper; 30 Hz is a common stereo-camera rate).
    seed : int
        Seeds the currents, the camera noise and the LSTM training.
    stiffness, remanence, damping, density : float
        The real robot's Young's modulus, magnet remanence, damping and rod density relative to the
        nominal model's (``ManipulatorSpec.scaled``). Defaults: +4 % stiffness (PMC-770's modulus
        depends on its cure; the paper tuned E until model and experiment agreed), -3 % remanence
        (the low end of the N42/N45 vendor ranges, 1.28 and 1.32 T against 1.30 and 1.35 T
        nominal), 2x the nominal damping (about 10 % of critical on the first mode instead of 5 %:
        rubber's loss factor is not known, and the static model has none at all), nominal density.
    field_amplitude : (3,)
        Peak [T] of the commanded field's x, y, z components at the workspace centre; y is the
        out-of-plane component (small: the paper's motion is planar, a real set-up is not exactly).
    field_band : (2,)
        Frequency band [Hz] of the commanded field (sums of sinusoids, log-uniform frequencies).
    current_peak : float
        Largest |I| as a fraction of the coil limit; the currents are scaled down to it if needed.
    settle : float
        Settling time [s] before the first sample, with the first sample's currents and heavy
        damping, so the record starts from rest.
    camera_noise : float
        Standard deviation [m] of the noise on each coordinate of each sampled centreline point
        (0.2 mm: about 4 pixels of a 1940-pixel camera across a 100 mm workspace, for segmentation
        and voxel reconstruction).
    camera_points : int
        Centreline points the camera reconstructs, evenly spaced in arc length over [0, L].
    polynomial_degree : int
        Degree of the polynomial P(s) fitted to each coordinate.
    static_steps : int
        RK4 steps N of the static Cosserat model (``StaticSolver.n_steps``).
    static_tol : float
        Its tolerance E on the tip wrench residual [N, N m].
    position_tol : float
        Fixed-point tolerance [m] on the magnets' positions between the static solve and the field.
    max_static_failures : float
        Largest fraction of samples whose static solve may fail (they are left out of the table and
        counted); beyond it the run stops with a ``SimulationError``.
    history : int
        LSTM history H (paper: 2).
    train_fraction : float
        Leading fraction of the samples the LSTMs train on (paper: 0.6); the rest is the test span.
    epochs : int or None
        Training epochs (None: 25 as the paper, or ``QUICK_EPOCHS`` = 8 with ``quick``).
    batch_size : int
        Windows per Adam step (the paper used 1).
    lstm_units : int
        LSTM units per layer.
    rollout_steps : int
        Steps of the multi-step training loss (``TrainConfig.rollout_steps``: the model's own
        predictions fed back); 1 is the paper's plain one-step training.
    output : str
        What the LSTM predicts (``ModelConfig.output``): ``"increment"`` (the next orientation minus
        the last; the most accurate one step ahead) or ``"pose"`` (the next orientation itself, as
        the paper; about 1.5x less accurate one step ahead here, but stable when free running).
    quick : bool
        Fewer samples and epochs (a smoke test under a minute).
    """

    samples: int | None = None
    sample_rate: float = 30.0
    seed: int = 0
    stiffness: float = 1.04
    remanence: float = 0.97
    damping: float = 2.0
    density: float = 1.0
    field_amplitude: tuple = (0.004, 0.001, 0.015)
    field_band: tuple = (0.05, 1.0)
    current_peak: float = 0.95
    settle: float = 0.5
    camera_noise: float = 2e-4
    camera_points: int = 100
    polynomial_degree: int = 3
    static_steps: int = 40
    static_tol: float = 1e-7
    position_tol: float = 1e-7
    max_static_failures: float = 0.05
    history: int = 2
    train_fraction: float = 0.6
    epochs: int | None = None
    batch_size: int = 8
    lstm_units: int = 32
    rollout_steps: int = 4
    output: str = "increment"
    quick: bool = False

    def __post_init__(self):
        if not isinstance(self.quick, (bool, np.bool_)):
            raise bad("quick", self.quick, "true or false")
        object.__setattr__(self, "quick", bool(self.quick))
        samples = (QUICK_SAMPLES if self.quick else FULL_SAMPLES) if self.samples is None else self.samples
        epochs = (QUICK_EPOCHS if self.quick else FULL_EPOCHS) if self.epochs is None else self.epochs
        object.__setattr__(self, "samples", _integer("samples", samples, 10))
        object.__setattr__(self, "epochs", _integer("epochs", epochs, 1))
        _number("sample_rate", self.sample_rate, positive=True, unit="Hz")
        if self.sample_rate > 1000:
            raise bad("sample_rate", self.sample_rate, "a camera rate up to 1000 Hz")
        object.__setattr__(self, "seed", _integer("seed", self.seed, 0))
        for name in ("stiffness", "remanence", "damping", "density"):
            _number(name, getattr(self, name), low=0.2, high=5.0,
                    unit="(the real robot's value over the nominal one, 1 = no perturbation)")
        amp = _triple("field_amplitude", self.field_amplitude, 3, "peak field components (Bx, By, Bz) in T, "
                                                                  "each in [0, 0.05]")
        if np.any(amp < 0) or np.any(amp > 0.05) or not np.any(amp > 0):
            raise bad("field_amplitude", self.field_amplitude, "peak field components (Bx, By, Bz) in T, each in "
                                                               "[0, 0.05], not all zero")
        band = _triple("field_band", self.field_band, 2, "(f_low, f_high) in Hz")
        if not 0 < band[0] < band[1] <= 0.25 * self.sample_rate:
            raise bad("field_band", self.field_band, f"0 < f_low < f_high <= sample_rate / 4 = "
                                                     f"{0.25 * self.sample_rate:g} Hz")
        object.__setattr__(self, "field_amplitude", tuple(float(a) for a in amp))
        object.__setattr__(self, "field_band", tuple(float(a) for a in band))
        _number("current_peak", self.current_peak, positive=True, high=1.0, unit="(fraction of the coil limit)")
        _number("settle", self.settle, low=0.0, high=10.0, unit="s")
        _number("camera_noise", self.camera_noise, low=0.0, high=0.005, unit="m")
        object.__setattr__(self, "camera_points", _integer("camera_points", self.camera_points, 4))
        deg = _integer("polynomial_degree", self.polynomial_degree, 2)
        if deg > 9 or deg >= self.camera_points:
            raise bad("polynomial_degree", deg, f"a degree in 2..{min(9, self.camera_points - 1)} (below "
                                                f"camera_points = {self.camera_points})")
        object.__setattr__(self, "polynomial_degree", deg)
        object.__setattr__(self, "static_steps", _integer("static_steps", self.static_steps, 6))
        _number("static_tol", self.static_tol, positive=True, unit="N, N m")
        _number("position_tol", self.position_tol, positive=True, high=1e-3, unit="m")
        _number("max_static_failures", self.max_static_failures, low=0.0, high=1.0, unit="(fraction of samples)")
        object.__setattr__(self, "history", _integer("history", self.history, 1))
        _number("train_fraction", self.train_fraction, low=0.1, high=0.9)
        object.__setattr__(self, "batch_size", _integer("batch_size", self.batch_size, 1))
        object.__setattr__(self, "lstm_units", _integer("lstm_units", self.lstm_units, 1))
        object.__setattr__(self, "rollout_steps", _integer("rollout_steps", self.rollout_steps, 1))
        if self.output not in ("increment", "pose"):
            raise bad("output", self.output, "'increment' (next minus last orientation) or 'pose' (next orientation)")
        cut = int(math.floor(self.train_fraction * self.samples))
        if min(cut, self.samples - cut) < self.history + 4:
            raise bad("samples", self.samples, f"enough samples for a training and a test span of at least "
                                               f"history + 4 = {self.history + 4} each (train_fraction "
                                               f"{self.train_fraction:g})")
        # the training span's last 20 % (TrainConfig.validation_fraction) validates the multi-step loss
        validation = cut - int(math.floor(cut * 0.8))
        need = self.history + self.rollout_steps
        if validation < need:
            least = next(n for n in range(self.samples, 100 * self.samples + 1000)
                         if (c := int(math.floor(self.train_fraction * n))) - int(math.floor(c * 0.8)) >= need)
            raise bad("samples", self.samples, f"at least {least} samples: the validation part of the training "
                                               f"span must hold history + rollout_steps = {need} samples")

    @property
    def dt(self) -> float:
        """Sample interval [s]."""
        return 1.0 / self.sample_rate

    def to_dict(self) -> dict:
        """JSON-ready fields (``ExperimentConfig(**d)`` rebuilds it)."""
        d = asdict(self)
        d["field_amplitude"], d["field_band"] = list(self.field_amplitude), list(self.field_band)
        return d

    def robot_spec(self, nominal: ManipulatorSpec | None = None) -> ManipulatorSpec:
        """The perturbed 'real robot' (the nominal spec scaled by the four factors)."""
        nominal = ManipulatorSpec() if nominal is None else nominal
        return nominal.scaled(stiffness=self.stiffness, remanence=self.remanence, damping=self.damping,
                              density=self.density)

    def simulation_fingerprint(self) -> str:
        """Hash of everything the real robot's record depends on (resuming checks it)."""
        keys = ("samples", "sample_rate", "seed", "stiffness", "remanence", "damping", "density",
                "field_amplitude", "field_band", "current_peak", "settle")
        d = {k: self.to_dict()[k] for k in keys}
        d["softrnn"] = __version__
        return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]


def _triple(name: str, value, n: int, expected: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        a = None
    if a is None or a.shape != (n,) or not np.all(np.isfinite(a)):
        raise bad(name, value, expected)
    return a


# ------------------------------------------------------------------------------------------ currents
def experiment_currents(spec: ManipulatorSpec, config: ExperimentConfig) -> CurrentSchedule:
    """Coil currents for the run: minimum-norm currents (pinv of the field block of the actuation
    matrix at the workspace centre) for a smooth random field B(t), sampled 10x finer than the
    camera so that the simulator's linear interpolation adds no kinks.

    Each field component c is a sum of 6 sinusoids with frequencies log-uniform in ``field_band``,
    random phases and amplitudes, scaled to the peak ``field_amplitude[c]`` [T]. The coil layout
    is mirror-symmetric about the xz-plane, so a field without y component keeps the rod in that
    plane; the y component adds the out-of-plane swing. The currents are scaled down together if
    any would exceed ``current_peak`` times the coil limit. Returns the schedule (times (K,) [s],
    values (K, 6) [A]), covering the (samples - 1) / sample_rate of the run.
    """
    rng = np.random.default_rng([config.seed, 0x6D61])
    fine = 10
    n = (config.samples - 1) * fine + 1
    t = np.arange(n) * (config.dt / fine)                                         # (K,) s
    f_lo, f_hi = config.field_band
    n_comp = 6
    B = np.zeros((n, 3))                                                           # (K, 3) T
    for c in range(3):
        freq = np.exp(rng.uniform(math.log(f_lo), math.log(f_hi), n_comp))
        phase = rng.uniform(0.0, 2.0 * math.pi, n_comp)
        amp = rng.uniform(0.5, 1.0, n_comp)
        s = np.sin(2.0 * math.pi * freq[None] * t[:, None] + phase[None]) @ amp   # (K,)
        peak = float(np.max(np.abs(s)))
        if config.field_amplitude[c] > 0 and peak > 0:
            B[:, c] = s * (config.field_amplitude[c] / peak)
    beta, _ = unit_field_maps(spec.coils, np.zeros(3))                             # (3, n_c) T/A
    I = B @ np.linalg.pinv(beta).T                                                 # (K, n_c) A
    top = float(np.max(np.abs(I)))
    limit = config.current_peak * spec.coils.current_limit
    if top > limit:
        I *= limit / top
    return CurrentSchedule(t, I)


# ------------------------------------------------------------------------------------------ camera
@dataclass(frozen=True, eq=False)
class CameraMeasurement:
    """What the camera model reads at M magnets over T samples.

    positions : (T, M, 3) [m] P(s_m) of the fitted polynomial
    tangents : (T, M, 3) unit dP/ds(s_m)
    orientations : (T, M, 3) [rad] rotation vectors phi_m k_m (``rotation_vectors``)
    """

    positions: np.ndarray
    tangents: np.ndarray
    orientations: np.ndarray


def rotation_vectors(tangents) -> np.ndarray:
    """Paper section 5.2: phi = acos(z . t), k = unit(z x t); returns phi k (..., 3) [rad] for unit
    (or any nonzero) tangents t (..., 3). A tangent along +z gives 0; one along -z gives (pi, 0, 0)
    by convention (k is undefined there)."""
    t = np.asarray(tangents, dtype=float)
    t = t / np.linalg.norm(t, axis=-1, keepdims=True)
    zxt = np.stack([-t[..., 1], t[..., 0], np.zeros(t.shape[:-1])], axis=-1)       # z x t
    s = np.linalg.norm(zxt, axis=-1)                                               # sin(phi)
    phi = np.arctan2(s, t[..., 2])                                                 # acos(z . t), robust
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(s[..., None] > 0, zxt / np.where(s > 0, s, 1.0)[..., None], np.array([1.0, 0.0, 0.0]))
    return phi[..., None] * k


def tangents_from_rotation_vectors(orientations) -> np.ndarray:
    """Inverse of ``rotation_vectors`` for k perpendicular to z: t = R(phi k) z = cos(phi) z +
    sin(phi) (k x z); (..., 3) [rad] -> unit (..., 3)."""
    r = np.asarray(orientations, dtype=float)
    phi = np.linalg.norm(r, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(phi[..., None] > 0, r / np.where(phi > 0, phi, 1.0)[..., None], 0.0)
    kxz = np.stack([k[..., 1], -k[..., 0], np.zeros(k.shape[:-1])], axis=-1)
    t = np.sin(phi)[..., None] * kxz
    t[..., 2] += np.cos(phi)
    return t / np.linalg.norm(t, axis=-1, keepdims=True)


def camera_measure(positions, s_nodes, s_magnets, noise: float, rng, *, points: int = 25,
                   degree: int = 5) -> CameraMeasurement:
    """The camera model: sample the centreline, add noise, fit P(s), read the magnets.

    Parameters
    ----------
    positions : (T, n, 3) [m]
        Centreline nodes of the rod (the real robot's, or any curve).
    s_nodes : (n,) [m]
        Their arc lengths, increasing from the base.
    s_magnets : (M,) [m]
        Arc lengths of the magnets' centres (constant: the paper assumes no extension).
    noise : float
        Standard deviation [m] of the Gaussian noise added to every coordinate of every sampled point.
    rng : numpy.random.Generator
    points : int
        Sampled centreline points, evenly spaced over [s_nodes[0], s_nodes[-1]] (linear
        interpolation between the nodes).
    degree : int
        Degree of the least-squares polynomial P(s) fitted to each coordinate (a Legendre basis
        on the scaled arc length, well conditioned).

    Returns
    -------
    CameraMeasurement
    """
    X = np.asarray(positions, dtype=np.float64)
    s = np.asarray(s_nodes, dtype=np.float64)
    sm = np.atleast_1d(np.asarray(s_magnets, dtype=np.float64))
    if X.ndim != 3 or X.shape[2] != 3 or X.shape[1] != s.shape[0] or s.ndim != 1 or s.shape[0] < 2:
        raise bad("positions", f"array of shape {X.shape}", f"(T, n, 3) with n = len(s_nodes) = {s.shape[0]} >= 2")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(s)) and np.all(np.diff(s) > 0)):
        raise bad("s_nodes", "non-increasing or non-finite values", "finite, strictly increasing arc lengths in m")
    if sm.ndim != 1 or np.any(sm < s[0]) or np.any(sm > s[-1]):
        raise bad("s_magnets", sm.tolist(), f"arc lengths in [{s[0]:g}, {s[-1]:g}] m")
    if not _is_int(points) or not _is_int(degree) or degree < 1 or points <= degree:
        raise bad("points, degree", (points, degree), "integers with points > degree >= 1")
    noise = _number("noise", noise, low=0.0, unit="m")
    from numpy.polynomial import legendre

    T, n = X.shape[0], s.shape[0]
    sc = np.linspace(s[0], s[-1], int(points))                                     # (P,)
    j = np.clip(np.searchsorted(s, sc, side="right") - 1, 0, n - 2)                # (P,)
    f = (sc - s[j]) / (s[j + 1] - s[j])                                            # (P,)
    Y = (1.0 - f)[None, :, None] * X[:, j] + f[None, :, None] * X[:, j + 1]        # (T, P, 3)
    if noise > 0:
        Y = Y + rng.normal(0.0, noise, size=Y.shape)
    lo, hi = s[0], s[-1]

    def scaled(a):
        return 2.0 * (a - lo) / (hi - lo) - 1.0

    V = legendre.legvander(scaled(sc), int(degree))                                # (P, d+1)
    coef, *_ = np.linalg.lstsq(V, Y.transpose(1, 0, 2).reshape(len(sc), -1), rcond=None)  # (d+1, T*3)
    Vm = legendre.legvander(scaled(sm), int(degree))                               # (M, d+1)
    dV = np.stack([legendre.legval(scaled(sm), legendre.legder(np.eye(int(degree) + 1)[k]))
                   for k in range(int(degree) + 1)], axis=-1)                      # (M, d+1) d/dx
    pos = (Vm @ coef).reshape(len(sm), T, 3).transpose(1, 0, 2)                    # (T, M, 3)
    d = (dV @ coef).reshape(len(sm), T, 3).transpose(1, 0, 2)                      # (T, M, 3)
    tangents = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return CameraMeasurement(positions=pos, tangents=tangents, orientations=rotation_vectors(tangents))


def camera_orientations(positions, s_nodes, s_magnets, noise: float, rng, *, points: int = 25,
                        degree: int = 5) -> np.ndarray:
    """The magnets' measured orientations (T, M, 3) [rad] (rotation vectors phi_m k_m); see
    ``camera_measure`` for the arguments."""
    return camera_measure(positions, s_nodes, s_magnets, noise, rng, points=points, degree=degree).orientations


# ------------------------------------------------------------------------------------------ wrenches
def _axial_moments(spec: ManipulatorSpec) -> np.ndarray:
    """Signed moment magnitudes (M,) [A m^2] of axially magnetised magnets (mu = m_j t)."""
    out = []
    for j, m in enumerate(spec.magnets):
        e = np.asarray(m.direction)
        if abs(abs(e[2]) - 1.0) > 1e-12:
            raise bad(f"magnets[{j}].direction", m.direction,
                      "an axial magnetisation (0, 0, +-1): a camera sees only the centreline's tangent, not "
                      "the rod's twist, so other directions cannot be placed from the measurement")
        out.append(m.moment * float(np.sign(e[2])))
    return np.array(out)


def measured_wrenches(spec: ManipulatorSpec, currents, positions, tangents) -> np.ndarray:
    """The magnet wrenches the paper fed to the LSTM: from the measured magnet positions (T, M, 3)
    [m] and tangents (T, M, 3), the nominal moments mu = (Br V / mu0) t of ``spec``'s axially
    magnetised magnets and the coil currents (T, n_c) [A]. Returns (T, M, 6) [N, N m] as
    [force G mu, torque mu x B], world frame."""
    I = spec.coils.check_currents(currents)
    p = np.asarray(positions, dtype=float)
    t = np.asarray(tangents, dtype=float)
    T, M = p.shape[:2]
    if I.shape != (T, spec.coils.n_coils) or t.shape != p.shape or M != len(spec.magnets):
        raise bad("currents, positions, tangents", (I.shape, p.shape, t.shape),
                  f"shapes (T, {spec.coils.n_coils}), (T, {len(spec.magnets)}, 3), (T, {len(spec.magnets)}, 3)")
    mu = _axial_moments(spec)[None, :, None] * t                                   # (T, M, 3)
    beta, grad = unit_field_maps(spec.coils, p.reshape(-1, 3))                     # (T*M, 3, n), (T*M, n, 3, 3)
    Ir = np.repeat(I, M, axis=0)                                                   # (T*M, n)
    B = np.einsum("pin,pn->pi", beta, Ir)                                          # (T*M, 3)
    G = np.einsum("pnij,pn->pij", grad, Ir)                                        # (T*M, 3, 3)
    return magnet_wrench(mu.reshape(-1, 3), B, G).reshape(T, M, 6)


# ------------------------------------------------------------------------------------------ static model
@dataclass(frozen=True, eq=False)
class StaticPrediction:
    """The static Cosserat model's predictions for T samples and M magnets.

    orientations : (T, M, 3) [rad] rotation vectors of the magnets' tangents (NaN where the solve failed)
    positions : (T, M, 3) [m] magnet centres (NaN where failed)
    converged : (T,) bool
    solves : (T,) int, static solves per sample (the fixed-point iterations)
    failures : tuple of (sample, message) for every failed sample
    seconds : float, wall time of all solves (Python calls included)
    """

    orientations: np.ndarray
    positions: np.ndarray
    converged: np.ndarray
    solves: np.ndarray
    failures: tuple
    seconds: float

    @property
    def solves_per_second(self) -> float:
        return float(self.solves.sum()) / self.seconds if self.seconds > 0 else math.inf

    @property
    def predictions_per_second(self) -> float:
        return float(self.converged.size) / self.seconds if self.seconds > 0 else math.inf


def static_rod(spec: ManipulatorSpec | None = None):
    """The static Cosserat model of the nominal manipulator: ``statics.study.magnetic_rod`` (rigid
    41.4 GPa magnet segments, PMC-770) placed at ``spec.base`` along +x, with ``spec``'s magnets as
    point dipoles. ``spec`` must keep the default rod and magnet geometry (length, diameter,
    magnets at L/2 and L - 1 mm, 2 mm cubes) that ``magnetic_rod`` builds."""
    from ...statics import PointMagnet
    from ..fig13 import MAGNET_SIDE, magnetic_rod

    spec = ManipulatorSpec() if spec is None else spec
    rod = magnetic_rod(length=spec.length, diameter=spec.diameter, gravity=spec.gravity)
    if len(spec.magnets) != len(rod.magnets) or any(
            abs(m.arc_length - pm.s) > 1e-9 or any(abs(a - MAGNET_SIDE) > 1e-12 for a in m.size)
            for m, pm in zip(spec.magnets, rod.magnets)):
        raise bad("spec.magnets", [(m.arc_length, m.size) for m in spec.magnets],
                  "the default magnets (2 mm cubes at L/2 and L - 1 mm) that the static model builds")
    if abs(spec.youngs_modulus - rod.youngs_modulus) > 1e-9 * rod.youngs_modulus \
            or abs(spec.density - rod.density) > 1e-9 * rod.density:
        raise bad("spec", "a modified rod material", "the nominal PMC-770 (E 2.5 MPa, rho 1000 kg/m^3) of the "
                                                     "static model; scale only the real robot")
    magnets = tuple(PointMagnet(s=m.arc_length, moment_body=tuple(m.moment_body)) for m in spec.magnets)
    return replace(rod, base_position=spec.base, magnets=magnets)


def static_predictions(currents, *, spec: ManipulatorSpec | None = None, n_steps: int = 40, tol: float = 1e-7,
                       position_tol: float = 1e-7, max_iterations: int = 30, max_failures: float = 0.05,
                       progress=None) -> StaticPrediction:
    """The static Cosserat model's magnet orientations for each sample of coil currents.

    For each sample the field B and gradient G at the magnets depend on where the magnets are, and
    where they are depends on B and G: starting from the previous sample's positions (the straight
    rod for the first), B and G are evaluated at the magnets, the static BVP is solved (warm-started
    ``StaticSolver``) and repeated with the new positions until they move less than
    ``position_tol`` [m] (about 5 iterations: the field changes little over the magnets' motion).

    A solve that does not converge is retried once from a cold start; a sample whose solve or fixed
    point still fails is recorded in ``failures`` (NaN in the arrays, never a silent value). More
    than ``max_failures`` (a fraction of the samples) failing raises ``SimulationError``.

    Parameters
    ----------
    currents : (T, n_c) [A]
        Coil currents, within the coil limit.
    spec : ManipulatorSpec or None
        The nominal manipulator (default ``ManipulatorSpec()``); see ``static_rod``.
    n_steps, tol :
        RK4 steps N and tolerance E of the static solver.
    position_tol : float
        Fixed-point tolerance [m].
    max_iterations : int
        Fixed-point iterations per sample.
    max_failures : float
        Largest tolerated fraction of failed samples.
    progress : callable(stage, done, total) or None
    """
    from ...statics import StaticLoads, StaticSolver, Status

    spec = ManipulatorSpec() if spec is None else spec
    I = spec.coils.check_currents(currents)
    if I.ndim != 2:
        raise bad("currents.shape", I.shape, f"(T, {spec.coils.n_coils}): one row of coil currents per sample")
    _number("position_tol", position_tol, positive=True, unit="m")
    _number("max_failures", max_failures, low=0.0, high=1.0)
    _integer("max_iterations", max_iterations, 1)
    rod = static_rod(spec)
    solver = StaticSolver(rod, n_steps=n_steps, tol=tol)
    T, M = I.shape[0], len(rod.magnets)
    coils = spec.coils
    rest = np.asarray(rod.base_position) + np.array([m.s for m in rod.magnets])[:, None] * rod.base_rotation[:, 2]
    out_r = np.full((T, M, 3), np.nan)
    out_p = np.full((T, M, 3), np.nan)
    converged = np.zeros(T, bool)
    solves = np.zeros(T, np.int64)
    failures = []
    p = rest.copy()
    t0 = time.perf_counter()
    for k in range(T):
        sol, why = None, ""
        for _ in range(max_iterations):
            beta, grad = unit_field_maps(coils, p)                                 # (M, 3, n), (M, n, 3, 3)
            loads = StaticLoads(magnetic_field=beta @ I[k], field_gradient=np.einsum("mnij,n->mij", grad, I[k]))
            sol = solver.solve(loads)
            solves[k] += 1
            if sol.status is not Status.CONVERGED:
                solver.reset()
                sol = solver.solve(loads)
                solves[k] += 1
            if sol.status is not Status.CONVERGED:
                why = f"static solve {sol.status.name.lower()}: {sol.message}"
                break
            idx = [sol.index(m.s) for m in rod.magnets]
            new = np.array(sol.positions[idx])
            moved = float(np.max(np.linalg.norm(new - p, axis=1)))
            p = new
            if moved <= position_tol:
                break
        else:
            why = (f"the magnets' positions did not settle in {max_iterations} fixed-point iterations (last move "
                   f"{moved:.3g} m > position_tol {position_tol:g} m)")
        if why:
            failures.append((k, why))
            p = rest.copy()
            solver.reset()
        else:
            converged[k] = True
            out_p[k] = p
            out_r[k] = rotation_vectors(sol.rotations[idx][:, :, 2])
        if progress is not None and (k % 10 == 9 or k == T - 1):
            progress("static", k + 1, T)
    seconds = time.perf_counter() - t0
    if len(failures) > max_failures * T:
        k, why = failures[0]
        raise SimulationError(f"the static Cosserat model failed on {len(failures)} of {T} samples "
                              f"({100 * len(failures) / T:.1f} % > max {100 * max_failures:g} %); first at sample "
                              f"{k}: {why}")
    return StaticPrediction(orientations=out_r, positions=out_p, converged=converged, solves=solves,
                            failures=tuple(failures), seconds=seconds)


# ------------------------------------------------------------------------------------------ data set
def orientation_dataset(time_s, orientations, wrenches, *, name: str = "magnetic-experiment",
                        extra: dict | None = None):
    """The paper's Data-set IV in memory: a ``softrnn.io.Dataset`` whose two 'nodes' are the magnets
    (0 proximal, 1 distal), whose positions hold their measured orientations (rotation vectors
    (T, 2, 3) [rad]) and whose forces and torques hold their wrenches (T, 2, 6) [N, N m]. The
    quaternions are identity placeholders (``has_orientations`` False)."""
    from ...io.dataset import Dataset

    t = np.asarray(time_s, dtype=float)
    r = np.asarray(orientations, dtype=float)
    w = np.asarray(wrenches, dtype=float)
    T = t.shape[0]
    if r.shape != (T, 2, 3) or w.shape != (T, 2, 6):
        raise bad("orientations, wrenches", (r.shape, w.shape), f"shapes ({T}, 2, 3) and ({T}, 2, 6)")
    q = np.zeros((T, 2, 4))
    q[..., 0] = 1.0
    dt = float(np.median(np.diff(t))) if T > 1 else 1.0
    attrs = {"units": {"time": "s", "positions": "rad (rotation vector phi k of the magnet's tangent, paper Sec. 5.2)",
                       "quaternions": "1 (identity placeholders)", "forces": "N", "torques": "N m"},
             "dt": dt, "n_nodes_total": 2, "rod": None, "has_orientations": False, "scenario_name": name,
             "nodes_are": "magnets: 0 proximal (s = L/2), 1 distal (s = L - 1 mm)", **(extra or {})}
    return Dataset(time=t, nodes=np.arange(2), positions=r, quaternions=q, forces=w[..., :3], torques=w[..., 3:],
                   attrs=attrs)


# ------------------------------------------------------------------------------------------ the comparison
def _errors_deg(predicted, measured) -> list:
    """[[max, mean] per axis] of |predicted - measured| [rad -> deg] over rows (K, 3), NaN rows left out."""
    d = np.degrees(np.abs(np.asarray(predicted, float) - np.asarray(measured, float)))     # (K, 3)
    d = d[np.all(np.isfinite(d), axis=1)]
    if d.shape[0] == 0:
        return [[None, None] for _ in AXES]
    return [[float(d[:, c].max()), float(d[:, c].mean())] for c in range(3)]


def _tangent_angles(orientations) -> np.ndarray:
    """(..., 2) [deg]: the tangent's elevation above the horizontal xy-plane (bending in the vertical
    plane, about y) and its heading in the xy-plane from +x (about z)."""
    t = tangents_from_rotation_vectors(orientations)
    return np.degrees(np.stack([np.arcsin(np.clip(t[..., 2], -1, 1)), np.arctan2(t[..., 1], t[..., 0])], -1))


def _angle_errors(predicted, measured) -> dict:
    d = np.abs(_tangent_angles(predicted) - _tangent_angles(measured))
    d = d[np.all(np.isfinite(d), axis=1)]
    if d.shape[0] == 0:
        return {"elevation": [None, None], "heading": [None, None]}
    return {name: [float(d[:, c].max()), float(d[:, c].mean())] for c, name in enumerate(("elevation", "heading"))}


def _stepper_rate(model, dataset, steps: int = 2000) -> float:
    """Batch-1 steps per second of the compiled ``NodeStepper`` fed the test span's rows."""
    from ...surrogate.data import pose_rows, wrench_rows
    from ...surrogate.engine import NodeStepper

    H = int(model.spec.history)
    rows = pose_rows(dataset, model.spec)
    wr = wrench_rows(dataset, model.spec)
    stepper = NodeStepper(model)
    stepper.reset(rows[:H], wr[:H])
    L = rows.shape[0]
    for i in range(100):
        stepper.step(rows[H + i % (L - H)], wr[H + i % (L - H)])
    t0 = time.perf_counter()
    for i in range(steps):
        k = H + i % (L - H)
        stepper.step(rows[k], wr[k])
    return steps / (time.perf_counter() - t0)


def _paper_table() -> dict:
    from ...paper import paper_case

    return paper_case("magnetic_experiment")["test_max_mean_abs_deg"]


def compare(dataset, static_orientations, config: ExperimentConfig, out_dir, *, progress=None,
            static_info: dict | None = None, figure_title: str = "") -> dict:
    """Train the two LSTMs (paper Fig. 11) on the first ``train_fraction`` of ``dataset``
    (``orientation_dataset``), predict the rest one step ahead and free running, and compare with
    the static model's ``static_orientations`` (T, 2, 3) [rad] (None: no static model) on the same
    targets. Writes ``out_dir/models/{proximal,distal}``, ``table1.json`` and ``fig12.png``;
    returns the table dict (see ``run_experiment``)."""
    from ...files import atomic_write_text
    from ...surrogate.data import SampleSpec
    from ...surrogate.evaluate import free_running, one_step
    from ...surrogate.rollout import RolloutDiverged
    from ...surrogate.train import TrainConfig, train_node_model

    out = Path(out_dir)
    measured = np.asarray(dataset.positions, dtype=np.float64)                     # (T, 2, 3) rad
    T = measured.shape[0]
    train = TrainConfig(epochs=config.epochs, batch_size=config.batch_size, seed=config.seed, patience=config.epochs,
                        rollout_steps=config.rollout_steps)
    result = {"unit": "deg", "axes": list(AXES), "orientation": ORIENTATION_NOTE}
    predictions = {}
    train_seconds = 0.0
    rates = {}
    for m, name in enumerate(MAGNETS):
        spec = SampleSpec(node=m, neighbours=(1 - m,), history=config.history, inputs="positions", wrench="wrench",
                          train_fraction=config.train_fraction)
        report = None if progress is None else (lambda d, n, info=None, s=f"train {name}": progress(s, d, n))
        t0 = time.perf_counter()
        overrides = {"lstm_units": config.lstm_units, "output": config.output}
        model = train_node_model(dataset, spec, overrides, train, out / MODELS_DIR / name, progress=report)
        train_seconds += time.perf_counter() - t0
        one = one_step(model, dataset)
        try:
            free = free_running(model, dataset)
            free_pred = free.predicted
        except RolloutDiverged:
            free_pred = None
        idx = one.index
        meas = measured[idx, m]
        entry = {"rnn": _errors_deg(one.predicted, meas),
                 "rnn_free_running": None if free_pred is None else _errors_deg(free_pred, meas),
                 "cosserat": None}
        angles = {"rnn": _angle_errors(one.predicted, meas)}
        if static_orientations is not None:
            st = np.asarray(static_orientations, float)[idx, m]
            entry["cosserat"] = _errors_deg(st, meas)
            angles["cosserat"] = _angle_errors(st, meas)
            entry["cosserat_samples"] = int(np.all(np.isfinite(st), axis=1).sum())
        entry["tangent_angles"] = angles
        entry["model"] = str(out / MODELS_DIR / name)
        entry["epochs_run"] = model.meta.get("epochs_run")
        entry["best_epoch"] = model.meta.get("best_epoch")
        result[name] = entry
        predictions[name] = {"index": idx, "rnn": one.predicted, "free": free_pred}
        rates[name] = _stepper_rate(model, dataset)
        if progress is not None:
            progress("evaluate", m + 1, len(MAGNETS))
    idx = predictions["distal"]["index"]
    motion = np.degrees(np.ptp(measured, axis=0))                                   # (2, 3) range per axis
    bending = AXES[int(np.argmax(motion.max(axis=0)))]
    b = AXES.index(bending)
    beats = beats_max = None
    if static_orientations is not None:
        def lower(name, k):
            r, c = result[name]["rnn"][b][k], result[name]["cosserat"][b][k]
            return bool(r is not None and c is not None and r < c)

        beats = {name: lower(name, 1) for name in MAGNETS}
        beats_max = {name: lower(name, 0) for name in MAGNETS}
    result.update({
        "paper": _paper_table(),
        "bending_axis": bending,
        "motion_range_deg": {name: [float(v) for v in motion[m]] for m, name in enumerate(MAGNETS)},
        "lstm_beats_static_on_bending_axis": beats,
        "lstm_beats_static_on_bending_axis_max": beats_max,
        "samples": int(T),
        "train_samples": int(math.floor(config.train_fraction * T)),
        "test_targets": int(idx.size),
        "test_time_s": [float(dataset.time[idx[0]]), float(dataset.time[idx[-1]])],
        "history": config.history,
        "static": static_info,
        "timings": {"training_s": train_seconds,
                    "rnn_steps_per_second": {name: float(rates[name]) for name in MAGNETS}},
    })
    fig = plot_fig12(np.asarray(dataset.time), measured, predictions,
                     None if static_orientations is None else np.asarray(static_orientations, float),
                     title=figure_title)
    from ...figures import plots as plotting

    plotting.save(fig, out / FIGURE_FILE)
    result["figure"] = str(out / FIGURE_FILE)
    atomic_write_text(out / TABLE_FILE, json.dumps(result, indent=2, allow_nan=False) + "\n")
    return result


def plot_fig12(time_s, measured, predictions: dict, static, title: str = ""):
    """Like the paper's Fig. 12: measured and predicted orientation over the test span, both magnets
    (columns), about y (the bending axis) and about x (rows), plus the absolute error about y;
    LSTM one step ahead (and free running, dotted), static Cosserat model. Returns the Figure."""
    from ...figures import plots as plotting  # noqa: F401  (selects the Agg backend)
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 2, figsize=(11, 7.5), sharex=True)
    for col, name in enumerate(("distal", "proximal")):
        m = MAGNETS.index(name)
        p = predictions[name]
        idx = p["index"]
        t = time_s[idx]
        for row, c in enumerate((1, 0)):
            ax = axes[row, col]
            ax.plot(t, np.degrees(measured[idx, m, c]), color="k", lw=1.2, label="measured (camera)")
            ax.plot(t, np.degrees(p["rnn"][:, c]), color="tab:blue", lw=1.0, label="LSTM, one step ahead")
            shown = [np.degrees(measured[idx, m, c]), np.degrees(p["rnn"][:, c])]
            if static is not None:
                ax.plot(t, np.degrees(static[idx, m, c]), color="tab:red", lw=1.0, label="static Cosserat model")
                shown.append(np.degrees(static[idx, m, c]))
            lo, hi = np.nanmin(np.concatenate(shown)), np.nanmax(np.concatenate(shown))
            pad = 0.15 * max(hi - lo, 1.0)
            if p["free"] is not None:                     # may drift far: keep the axis on the others
                ax.plot(t, np.degrees(p["free"][:, c]), color="tab:blue", lw=0.8, ls=":",
                        label="LSTM, free running (may leave the axis)")
            ax.set_ylim(lo - pad, hi + pad)
            ax.set_ylabel(f"{name}: about {AXES[c]} [deg]")
            ax.grid(alpha=0.3)
        ax = axes[2, col]
        ax.plot(t, np.degrees(np.abs(p["rnn"][:, 1] - measured[idx, m, 1])), color="tab:blue", lw=0.8, label="LSTM")
        if static is not None:
            ax.plot(t, np.degrees(np.abs(static[idx, m, 1] - measured[idx, m, 1])), color="tab:red", lw=0.8,
                    label="static Cosserat")
        ax.set_ylabel(f"{name}: |error| about y [deg]")
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    axes[2, 0].legend(fontsize=7, loc="best")
    fig.suptitle(title or "Magnet orientations over the test span (the paper's Fig. 12)", fontsize=10)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------------------------ the experiment
def _simulate_robot(config: ExperimentConfig, spec: ManipulatorSpec, path: Path, progress) -> tuple:
    """(time (T,), node positions (T, n, 3) as stored (float32), currents (T, n_c), wall seconds, resumed)."""
    from ...io.dataset import DatasetError, read_dataset, write_trajectory

    fingerprint = config.simulation_fingerprint()
    if path.exists():
        try:
            data = read_dataset(path)
            if data.attrs.get("experiment_fingerprint") == fingerprint:
                if progress is not None:
                    progress("simulate", 1, 1)
                return (data.time, np.asarray(data.positions, np.float64), np.asarray(data.attrs["currents"], float),
                        float(data.attrs.get("simulation_seconds", 0.0)), True)
        except (DatasetError, KeyError, TypeError, ValueError):
            pass                                                                   # re-simulate and replace it
    if progress is not None:
        progress("simulate", 0, 1)
    robot = config.robot_spec(spec)
    schedule = experiment_currents(spec, config)
    run = ManipulatorRun(dt=config.dt, n_samples=config.samples, settle=config.settle)
    t0 = time.perf_counter()
    traj = simulate_manipulator(robot, schedule, run)
    seconds = time.perf_counter() - t0
    attrs = {"experiment_fingerprint": fingerprint, "experiment": config.to_dict(),
             "currents": traj.currents.tolist(), "currents_units": "A, one row per sample, coils 0..5",
             "simulation_seconds": seconds, "scenario_name": "magnetic-experiment-robot",
             "description": "the simulated 'real robot' of the magnetic experiment (softrnn.experiments.magnetic.experiment)"}
    write_trajectory(path, traj.rod, dt=config.dt, rod=robot.rod_spec(), seed=config.seed, attrs=attrs,
                     scenario_text=json.dumps(config.to_dict()))
    if progress is not None:
        progress("simulate", 1, 1)
    stored = read_dataset(path)
    return stored.time, np.asarray(stored.positions, np.float64), traj.currents, seconds, False


def assumptions(config: ExperimentConfig) -> dict:
    """The documented modelling choices of the simulated experiment (for the report)."""
    return {
        "robot": f"the dynamic Cosserat model (softrnn.magnetics, 26 nodes, magnetic.md defaults: L 50 mm, D 3 mm, "
                 f"N42 at L/2 and N45 at L - 1 mm) plays the real robot with Young's modulus x{config.stiffness:g}, "
                 f"remanence x{config.remanence:g}, damping x{config.damping:g} and density x{config.density:g} of "
                 f"the nominal values the static model uses, so the comparison is not circular",
        "currents": f"minimum-norm coil currents for a smooth random field at the workspace centre, peaks "
                    f"{[round(1e3 * a, 3) for a in config.field_amplitude]} mT (x, y, z), {config.field_band[0]:g}-"
                    f"{config.field_band[1]:g} Hz; y is out of plane (the paper's motion is planar); "
                    f"{config.settle:g} s of settling before the first sample",
        "camera": f"{config.camera_points} centreline points at {config.sample_rate:g} Hz with "
                  f"{1e3 * config.camera_noise:g} mm Gaussian noise per coordinate, a degree-"
                  f"{config.polynomial_degree} polynomial P(s) per coordinate, magnet pose from P(s_m) and "
                  f"dP/ds(s_m) (paper Sec. 5.2)",
        "orientation": ORIENTATION_NOTE,
        "static_model": f"static Cosserat BVP (softrnn.statics, RK4 N = {config.static_steps}, E = "
                        f"{config.static_tol:g}) with the nominal parameters, from the currents alone; B and G at "
                        f"the magnets by fixed-point iteration on their positions (to {config.position_tol:g} m); "
                        f"failed samples are counted and left out, never used",
        "lstm": f"paper Fig. 11: one model per magnet, input I both magnets' measured orientations, input II the "
                f"magnet's wrench [f, tau] from the measured pose, the nominal moment and the currents (as the "
                f"paper computed it); history {config.history}, first {100 * config.train_fraction:g} % for "
                f"training (its last 20 % for early stopping), {config.epochs} epochs, batch {config.batch_size}, "
                f"2 x {config.lstm_units} LSTM units",
        "evaluation": "errors against the camera measurement on the test span; the LSTM one step ahead from the "
                      "measured history (as Table 1) and free running (own history, the other magnet measured)",
    }


def run_experiment(config: ExperimentConfig, out_dir, progress=None) -> dict:
    """Run the simulated experiment into ``out_dir`` and return the report.

    Files: ``robot.h5`` (the real robot's record: every node, the currents in its attrs; reused when
    it exists with the same simulation settings), ``models/proximal`` and ``models/distal`` (the
    LSTMs), ``table1.json`` (the report) and ``fig12.png``.

    Returns
    -------
    dict (JSON-ready)
        ``distal`` and ``proximal``, each with ``rnn``, ``cosserat`` and ``rnn_free_running`` as
        [[max, mean] per axis x, y, z] in degrees (and ``tangent_angles``); ``paper`` (Table 1 in the
        same shape); ``bending_axis`` (the axis of the largest measured range); per magnet
        ``lstm_beats_static_on_bending_axis`` (a lower mean error about it) and ``..._max`` (a lower
        max error); ``static`` (failures,
        solves); ``timings`` (simulation, static, training and total seconds, static solves and
        predictions per second, LSTM steps per second); ``assumptions``; ``config``; ``files``.
    """
    if not isinstance(config, ExperimentConfig):
        raise bad("config", type(config).__name__, "an ExperimentConfig")
    t_start = time.perf_counter()
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise bad("out_dir", str(out), "a folder (it exists and is a file)")
    spec = ManipulatorSpec()
    # refuse an absurd run before the currents are made and the folder is created
    check_manipulator_run(config.robot_spec(spec), ManipulatorRun(dt=config.dt, n_samples=config.samples,
                                                                  settle=config.settle),
                          extra_bytes=(config.samples - 1) * 10 * 17 * 8)   # experiment_currents' arrays
    out.mkdir(parents=True, exist_ok=True)
    time_s, X, currents, sim_seconds, resumed = _simulate_robot(config, spec, out / ROBOT_FILE, progress)
    s_nodes = np.linspace(0.0, spec.length, spec.n_nodes)
    s_magnets = np.array([m.arc_length for m in spec.magnets])
    rng = np.random.default_rng([config.seed, 0x63616D])
    cam = camera_measure(X, s_nodes, s_magnets, config.camera_noise, rng, points=config.camera_points,
                         degree=config.polynomial_degree)
    wrenches = measured_wrenches(spec, currents, cam.positions, cam.tangents)
    if progress is not None:
        progress("camera", 1, 1)
    static = static_predictions(currents, spec=spec, n_steps=config.static_steps, tol=config.static_tol,
                                position_tol=config.position_tol, max_failures=config.max_static_failures,
                                progress=progress)
    static_info = {"failures": len(static.failures), "failed_samples": [k for k, _ in static.failures][:20],
                   "first_failure": static.failures[0][1] if static.failures else None,
                   "solves": int(static.solves.sum()), "mean_solves_per_sample": float(static.solves.mean()),
                   "n_steps": config.static_steps, "tol": config.static_tol}
    dataset = orientation_dataset(time_s, cam.orientations, wrenches, extra={"experiment": config.to_dict()})
    result = compare(dataset, static.orientations, config, out, progress=progress, static_info=static_info,
                     figure_title=f"Simulated magnetic experiment ({config.samples} samples at "
                                  f"{config.sample_rate:g} Hz): orientations over the test span (the paper's Fig. 12)")
    result["timings"].update({
        "simulation_s": sim_seconds, "simulation_resumed": resumed,
        "simulated_seconds": float(time_s[-1] - time_s[0]) + config.settle,
        "static_s": static.seconds, "static_solves_per_second": static.solves_per_second,
        "static_predictions_per_second": static.predictions_per_second,
        "total_s": time.perf_counter() - t_start})
    result["assumptions"] = assumptions(config)
    result["config"] = config.to_dict()
    result["files"] = {"robot": str(out / ROBOT_FILE), "table": str(out / TABLE_FILE), "figure": result["figure"],
                       "models": {name: result[name]["model"] for name in MAGNETS}}
    from ...files import atomic_write_text

    atomic_write_text(out / TABLE_FILE, json.dumps(result, indent=2, allow_nan=False) + "\n")
    return result


def format_table(result: dict) -> list[str]:
    """Table 1 beside the paper's as text lines: per magnet and model, (max, mean) [deg] about x, y, z."""
    def cell(v):
        return "-" if v is None or v[0] is None else f"({v[0]:.2f}, {v[1]:.2f})"

    lines = [f"{'':34}{'x-axis':>18}{'y-axis':>18}{'z-axis':>18}"]
    for name in ("distal", "proximal"):
        lines.append(f"{name} magnet")
        rows = [("LSTM (one step ahead)", result[name]["rnn"]),
                ("LSTM (free running)", result[name].get("rnn_free_running")),
                ("static Cosserat model", result[name].get("cosserat")),
                ("paper: RNN-based model", result["paper"][name]["rnn"]),
                ("paper: Cosserat rod model", result["paper"][name]["cosserat"])]
        for label, table in rows:
            cells = ["-"] * 3 if table is None else [cell(v) for v in table]
            lines.append(f"  {label:32}" + "".join(f"{c:>18}" for c in cells))
    return lines


def check_result_shape(result: dict) -> None:
    """Raise ``SoftrnnInputError`` unless ``result`` has the documented Table 1 shape (tests, reproduce)."""
    for name in MAGNETS:
        for model in ("rnn", "cosserat"):
            table = result.get(name, {}).get(model)
            if table is None and model == "cosserat":
                continue
            ok = isinstance(table, list) and len(table) == 3 and all(
                isinstance(v, list) and len(v) == 2 and all(isinstance(x, float) for x in v) for v in table)
            if not ok:
                raise SoftrnnInputError(f"result[{name!r}][{model!r}]={table!r} is invalid: expected [[max, mean] "
                                        f"per axis x, y, z] in degrees")
