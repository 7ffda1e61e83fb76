"""Configuration of the simulated magnetic experiment (paper section 5): ``ExperimentConfig`` and the fixed names."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass

import numpy as np

from ... import __version__
from ...errors import bad, integer
from ...magnetics.manipulator import ManipulatorSpec
from ...magnetics.plant import PLANT
from ._checks import number, triple

MAGNETS = ("proximal", "distal")
"""Magnet names in index order (0 at L/2, 1 at the tip; the paper's m = 1, 2 from the base)."""

AXES = ("x", "y", "z")
"""The world axes of the orientation components (rotation vectors (..., 3) [rad] in this order)."""

STAGES = ("simulate", "camera", "calibrate", "predict", "static", "train proximal", "train distal", "evaluate")
"""The stages the experiment reports, in order, as ``info["stage"]`` of ``progress(done, total, info)``."""

QUICK_SAMPLES = 240
QUICK_EPOCHS = 8
FULL_SAMPLES = 669
FULL_EPOCHS = 25
QUICK_CALIBRATION_EVALUATIONS = 5
FULL_CALIBRATION_EVALUATIONS = 12

ROBOT_FILE = "robot.h5"
TABLE_FILE = "table1.json"
FIGURE_FILE = "fig12.png"
MODELS_DIR = "models"
CALIBRATION_FILE = "calibration.json"
"""File and folder names inside the output folder (the real robot's record, Table 1, Fig. 12, the LSTMs)."""

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
"""What the reported orientations are (written into ``table1.json`` and the report)."""


@dataclass(frozen=True, kw_only=True)
class ExperimentConfig:
    """The simulated experiment (defaults: the paper's 669 samples, history 2, 60 % training; the
    plant's and the camera's: ``softrnn.magnetics.plant.PLANT``).

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
    calibrate : bool
        Also fit the dynamic Cosserat model's stiffness, remanence and damping factors to the camera
        record of the training span (``calibration``), and predict the test span with it from the
        currents alone (the "calibrated dynamic Cosserat" row of Table 1).
    calibration_fraction : float
        Leading fraction of the training span the calibration fits to (0.5: the first 6.7 s of the
        paper-length record; enough to fix stiffness and remanence to 0.1 % and damping to a few %;
        each trial simulates the span at a 3 us step).
    calibration_evaluations : int
        Largest number of points the calibration's optimiser evaluates (``FitOptions.max_evaluations``;
        None: 12, or ``QUICK_CALIBRATION_EVALUATIONS`` = 5 with ``quick``: the fit may stop before it
        converges). Each point costs four simulations of the calibration span.
    quick : bool
        Fewer samples, epochs and calibration points (a smoke test of about two minutes on 2 cores).
    """

    samples: int | None = None
    sample_rate: float = PLANT.rate
    seed: int = 0
    stiffness: float = PLANT.stiffness
    remanence: float = PLANT.remanence
    damping: float = PLANT.damping
    density: float = 1.0
    field_amplitude: tuple = (0.004, 0.001, 0.015)
    field_band: tuple = (0.05, 1.0)
    current_peak: float = 0.95
    settle: float = PLANT.settle
    camera_noise: float = PLANT.camera_noise
    camera_points: int = PLANT.camera_points
    polynomial_degree: int = PLANT.polynomial_degree
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
    calibrate: bool = True
    calibration_fraction: float = 0.5
    calibration_evaluations: int | None = None
    quick: bool = False

    def __post_init__(self):
        if not isinstance(self.quick, (bool, np.bool_)):
            raise bad("quick", self.quick, "true or false")
        object.__setattr__(self, "quick", bool(self.quick))
        samples = (QUICK_SAMPLES if self.quick else FULL_SAMPLES) if self.samples is None else self.samples
        epochs = (QUICK_EPOCHS if self.quick else FULL_EPOCHS) if self.epochs is None else self.epochs
        object.__setattr__(self, "samples", integer("samples", samples, 10))
        object.__setattr__(self, "epochs", integer("epochs", epochs, 1))
        self._check_robot_and_field()
        self._check_camera_and_static()
        self._check_training()
        self._check_spans()

    def _check_robot_and_field(self) -> None:
        """The camera rate, seed, the real robot's factors and the commanded field (normalised in place)."""
        number("sample_rate", self.sample_rate, positive=True, unit="Hz")
        if self.sample_rate > 1000:
            raise bad("sample_rate", self.sample_rate, "a camera rate up to 1000 Hz")
        object.__setattr__(self, "seed", integer("seed", self.seed, 0))
        for name in ("stiffness", "remanence", "damping", "density"):
            number(name, getattr(self, name), low=0.2, high=5.0,
                   unit="(the real robot's value over the nominal one, 1 = no perturbation)")
        amp = triple("field_amplitude", self.field_amplitude, 3, "peak field components (Bx, By, Bz) in T, "
                                                                 "each in [0, 0.05]")
        if np.any(amp < 0) or np.any(amp > 0.05) or not np.any(amp > 0):
            raise bad("field_amplitude", self.field_amplitude, "peak field components (Bx, By, Bz) in T, each in "
                                                               "[0, 0.05], not all zero")
        band = triple("field_band", self.field_band, 2, "(f_low, f_high) in Hz")
        if not 0 < band[0] < band[1] <= 0.25 * self.sample_rate:
            raise bad("field_band", self.field_band, f"0 < f_low < f_high <= sample_rate / 4 = "
                                                     f"{0.25 * self.sample_rate:g} Hz")
        object.__setattr__(self, "field_amplitude", tuple(float(a) for a in amp))
        object.__setattr__(self, "field_band", tuple(float(a) for a in band))
        number("current_peak", self.current_peak, positive=True, high=1.0, unit="(fraction of the coil limit)")
        number("settle", self.settle, low=0.0, high=10.0, unit="s")

    def _check_camera_and_static(self) -> None:
        """The camera model's and the static model's settings."""
        number("camera_noise", self.camera_noise, low=0.0, high=0.005, unit="m")
        object.__setattr__(self, "camera_points", integer("camera_points", self.camera_points, 4))
        deg = integer("polynomial_degree", self.polynomial_degree, 2)
        if deg > 9 or deg >= self.camera_points:
            raise bad("polynomial_degree", deg, f"a degree in 2..{min(9, self.camera_points - 1)} (below "
                                                f"camera_points = {self.camera_points})")
        object.__setattr__(self, "polynomial_degree", deg)
        object.__setattr__(self, "static_steps", integer("static_steps", self.static_steps, 6))
        number("static_tol", self.static_tol, positive=True, unit="N, N m")
        number("position_tol", self.position_tol, positive=True, high=1e-3, unit="m")
        number("max_static_failures", self.max_static_failures, low=0.0, high=1.0, unit="(fraction of samples)")

    def _check_training(self) -> None:
        """The LSTMs' settings."""
        object.__setattr__(self, "history", integer("history", self.history, 1))
        number("train_fraction", self.train_fraction, low=0.1, high=0.9)
        object.__setattr__(self, "batch_size", integer("batch_size", self.batch_size, 1))
        object.__setattr__(self, "lstm_units", integer("lstm_units", self.lstm_units, 1))
        object.__setattr__(self, "rollout_steps", integer("rollout_steps", self.rollout_steps, 1))
        if not isinstance(self.calibrate, (bool, np.bool_)):
            raise bad("calibrate", self.calibrate, "true or false")
        object.__setattr__(self, "calibrate", bool(self.calibrate))
        number("calibration_fraction", self.calibration_fraction, low=0.05, high=1.0,
               unit="(leading fraction of the training span)")
        evaluations = self.calibration_evaluations
        if evaluations is None:
            evaluations = QUICK_CALIBRATION_EVALUATIONS if self.quick else FULL_CALIBRATION_EVALUATIONS
        object.__setattr__(self, "calibration_evaluations", integer("calibration_evaluations", evaluations, 2))
        if self.output not in ("increment", "pose"):
            raise bad("output", self.output, "'increment' (next minus last orientation) or 'pose' (next orientation)")

    def _check_spans(self) -> None:
        """Enough samples for the training, validation and test spans."""
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

    def calibration_samples(self, samples: int | None = None) -> int:
        """Samples the calibration fits to: the leading ``calibration_fraction`` of the training span
        of a record of ``samples`` (None: ``self.samples``)."""
        T = self.samples if samples is None else int(samples)
        return max(8, int(math.floor(self.calibration_fraction * math.floor(self.train_fraction * T))))

    def simulation_fingerprint(self) -> str:
        """Hash of everything the real robot's record depends on (resuming checks it)."""
        keys = ("samples", "sample_rate", "seed", "stiffness", "remanence", "damping", "density",
                "field_amplitude", "field_band", "current_peak", "settle")
        d = {k: self.to_dict()[k] for k in keys}
        d["softrnn"] = __version__
        return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]

