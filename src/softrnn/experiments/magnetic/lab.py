"""Lab data of the magnetic experiment in CSV (layout and rules: docs/magnetic-format.md), and the
paper's comparison on it: the static Cosserat model from the coil currents against the LSTMs trained
on the first 60 % (``compare_lab``), written like the simulated experiment's Table 1.

One line per sample::

    time,I0,I1,I2,I3,I4,I5,m0_rx,m0_ry,m0_rz,m1_rx,m1_ry,m1_rz[,m0_x,m0_y,m0_z,m1_x,m1_y,m1_z]
    0.0000,1.2,-0.8,...

``time`` [s] first; coil currents ``I0..I5`` [A] and/or magnet wrenches ``m{j}_fx, m{j}_fy, m{j}_fz,
m{j}_tx, m{j}_ty, m{j}_tz`` [N, N m]; the measured orientations ``m{j}_rx, m{j}_ry, m{j}_rz`` as the
rotation vector phi_m k_m of paper section 5.2 in degrees; optionally the magnet positions
``m{j}_x, m{j}_y, m{j}_z`` [m]. Magnet 0 is the proximal one (s = L/2), 1 the distal one. Every
problem is a one-line ``SoftrnnInputError`` naming the file, the line and the column.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import SoftrnnInputError, bad
from ...files import atomic_write_text
from ...io.csv_table import CellWords, parse_cells, read_csv_lines, shown, time_steps
from ...magnetics.camera import camera_measure, tangents_from_rotation_vectors
from ...magnetics.manipulator import ManipulatorRun, ManipulatorSpec, simulate_manipulator
from ...magnetics.static import static_predictions
from ...progress import Progress
from .comparison import compare
from .config import ExperimentConfig
from .currents import experiment_currents
from .dataset import measured_wrenches, orientation_dataset
from .run import calibrate_and_predict, check_experiment_size
from .static import static_summary

N_COILS = 6
N_MAGNETS = 2
CURRENTS = tuple(f"I{k}" for k in range(N_COILS))
ORIENTATION = tuple(f"m{j}_r{c}" for j in range(N_MAGNETS) for c in "xyz")
POSITION = tuple(f"m{j}_{c}" for j in range(N_MAGNETS) for c in "xyz")
WRENCH = tuple(f"m{j}_{c}" for j in range(N_MAGNETS) for c in ("fx", "fy", "fz", "tx", "ty", "tz"))
KNOWN = ("time",) + CURRENTS + ORIENTATION + POSITION + WRENCH
LAYOUT = ("time, I0..I5 [A] and/or m{j}_fx,m{j}_fy,m{j}_fz,m{j}_tx,m{j}_ty,m{j}_tz [N, N m], "
          "m{j}_rx,m{j}_ry,m{j}_rz [deg], optional m{j}_x,m{j}_y,m{j}_z [m], for magnets j = 0 (proximal) and "
          "1 (distal); see docs/magnetic-format.md")
_NUMBER = "every cell must be a number (decimal point '.', no units)"
WORDS = CellWords(width="line {line} has {cells} cells but the header has {width} columns; every row needs one value "
                        "per column",
                  empty="line {line}, column {name!r}: the cell is empty; " + _NUMBER,
                  not_number="line {line}, column {name!r}: the cell {text} is not a number; " + _NUMBER,
                  not_finite="line {line}, column {name!r}: {text} is not a finite number; every value must be finite")
"""How the lab CSV's reader words a bad row or cell (``softrnn.io.csv_table.CellWords``)."""
DT_SPREAD = 0.1
"""Largest relative deviation of a time step from the median step (the LSTM assumes a constant interval)."""


def _fail(path: Path, message: str) -> SoftrnnInputError:
    return SoftrnnInputError(f"{path}: {message}")


@dataclass(frozen=True, eq=False)
class LabData:
    """A magnetic lab record of T samples (magnet 0 proximal, 1 distal; world frame of the coils).

    Attributes
    ----------
    time : (T,) [s]
        the sample times
    currents : (T, 6) [A] or None
        the coil currents
    orientations : (T, 2, 3) [rad]
        rotation vectors phi k (stored in the CSV in degrees)
    positions : (T, 2, 3) [m] or None
        the magnet centres
    wrenches : (T, 2, 6) [N, N m] or None
        [force, torque] on each magnet
    path : str
        the file read
    """

    time: np.ndarray
    currents: np.ndarray | None
    orientations: np.ndarray
    positions: np.ndarray | None
    wrenches: np.ndarray | None
    path: str = ""

    @property
    def n_samples(self) -> int:
        """T, the number of samples."""
        return int(self.time.shape[0])


# ----------------------------------------------------------------------------------------- reading
def _lines(path: Path) -> list[tuple[int, str]]:
    return read_csv_lines(path, f"the columns {LAYOUT}", SoftrnnInputError)


def _header(path: Path, number: int, line: str) -> list[str]:
    names = [c.strip() for c in line.split(",")]
    lower = {k.lower(): k for k in KNOWN}
    out = []
    for j, name in enumerate(names):
        if not name:
            raise _fail(path, f"line {number} (header): column {j + 1} has no name (a stray or trailing comma?)")
        key = lower.get(name.lower())
        if key is None:
            raise _fail(path, f"line {number} (header): column {shown(name)} is not recognised; expected {LAYOUT}")
        if key in out:
            raise _fail(path, f"line {number} (header): column {key!r} appears twice")
        out.append(key)
    if out[0] != "time":
        raise _fail(path, f"line {number} (header): the first column is {shown(names[0])}; expected 'time' [s]")
    missing = [c for c in ORIENTATION if c not in out]
    if missing:
        raise _fail(path, f"line {number} (header): missing column{'s' if len(missing) > 1 else ''} "
                          f"{', '.join(missing)}: the measured orientations of both magnets are required")
    for group, what in ((CURRENTS, "the coil currents I0..I5"), (POSITION, "the magnet positions"),
                        (WRENCH, "the magnet wrenches")):
        have = [c for c in group if c in out]
        if have and len(have) != len(group):
            lack = [c for c in group if c not in out]
            raise _fail(path, f"line {number} (header): missing column{'s' if len(lack) > 1 else ''} "
                              f"{', '.join(lack)}: {what} are given for all or none")
    if CURRENTS[0] not in out and WRENCH[0] not in out:
        raise _fail(path, f"line {number} (header): missing columns I0..I5 (or the magnet wrenches "
                          f"m0_fx..m1_tz): the models need the actuation")
    return out


def read_lab_csv(path, *, spec: ManipulatorSpec | None = None) -> LabData:
    """Parse and check a magnetic lab CSV (docs/magnetic-format.md).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    spec : ManipulatorSpec or None
        The manipulator whose coil limit the currents must respect (default ``ManipulatorSpec()``,
        +/-8 A).

    Raises
    ------
    SoftrnnInputError
        One line naming the file (and the line and column): a missing, folder, binary, UTF-16 or
        semicolon-separated file (``read_csv_lines``), missing columns, unknown or
        duplicate columns, a non-numeric or non-finite cell, a current beyond the coil limit, times
        that do not increase or are not evenly spaced, orientations beyond 180 deg, too few rows.
    """
    path = Path(path)
    spec = ManipulatorSpec() if spec is None else spec
    lines = _lines(path)
    names = _header(path, *lines[0])
    rows = lines[1:]
    if len(rows) < 2:
        raise _fail(path, f"has {len(rows)} data row{'s' if len(rows) != 1 else ''}; a comparison needs a few hundred")
    V = parse_cells(path, names, rows, words=WORDS, error=SoftrnnInputError)
    col = {name: j for j, name in enumerate(names)}
    t = V[:, 0]
    step = time_steps(path, rows, t, "times must increase strictly: sort the rows and drop duplicated ones")
    median = float(np.median(step))
    off = np.abs(step - median) / median
    if np.any(off > DT_SPREAD):
        i = int(np.argmax(off))
        raise _fail(path, f"line {rows[i + 1][0]}: the time step {step[i]:.6g} s differs from the median "
                          f"{median:.6g} s by {100 * off[i]:.0f} % (> {100 * DT_SPREAD:g} %); the models need "
                          f"evenly spaced samples: resample the record")
    currents = None
    if CURRENTS[0] in col:
        currents = V[:, [col[c] for c in CURRENTS]]
        limit = spec.coils.current_limit
        beyond = np.abs(currents) > limit * (1 + 1e-12)
        if beyond.any():
            i, k = (int(a) for a in np.argwhere(beyond)[0])
            raise _fail(path, f"line {rows[i][0]}, column {CURRENTS[k]!r}: {currents[i, k]:g} A is beyond the coil "
                              f"limit +/-{limit:g} A")
    r = np.radians(V[:, [col[c] for c in ORIENTATION]]).reshape(-1, N_MAGNETS, 3)
    big = np.linalg.norm(r, axis=-1) > math.pi * (1 + 1e-9)
    if big.any():
        i, j = (int(a) for a in np.argwhere(big)[0])
        raise _fail(path, f"line {rows[i][0]}, columns m{j}_rx..m{j}_rz: a rotation vector of "
                          f"{math.degrees(np.linalg.norm(r[i, j])):.4g} deg; expected phi k with phi in [0, 180] deg")
    positions = None
    if POSITION[0] in col:
        positions = V[:, [col[c] for c in POSITION]].reshape(-1, N_MAGNETS, 3)
        far = np.linalg.norm(positions, axis=-1) > spec.coils.workspace_radius
        if far.any():
            i, j = (int(a) for a in np.argwhere(far)[0])
            raise _fail(path, f"line {rows[i][0]}, columns m{j}_x..m{j}_z: the magnet is "
                              f"{np.linalg.norm(positions[i, j]):.4g} m from the workspace centre, beyond its radius "
                              f"{spec.coils.workspace_radius:g} m (positions are in m, origin at the centre)")
    wrenches = None
    if WRENCH[0] in col:
        wrenches = V[:, [col[c] for c in WRENCH]].reshape(-1, N_MAGNETS, 6)
    return LabData(time=t, currents=currents, orientations=r, positions=positions, wrenches=wrenches, path=str(path))


# ----------------------------------------------------------------------------------------- writing
def _fmt(values, digits: int) -> list[str]:
    return [f"{v:.{digits}f}" for v in values]


def write_lab_csv(path, data: LabData, *, comment: str = "") -> None:
    """Write ``data`` in the lab format (atomically): currents and wrenches and positions where
    present, orientations in degrees. Values are rounded (time 1e-6 s, currents 1e-4 A, orientations
    1e-4 deg, positions 1e-7 m, wrenches 6 significant digits)."""
    names = ["time"]
    if data.currents is not None:
        names += CURRENTS
    names += ORIENTATION
    if data.positions is not None:
        names += POSITION
    if data.wrenches is not None:
        names += WRENCH
    lines = [f"# {line}" for line in comment.splitlines()] if comment else []
    lines.append(",".join(names))
    deg = np.degrees(data.orientations)
    for i in range(data.n_samples):
        cells = _fmt([data.time[i]], 6)
        if data.currents is not None:
            cells += _fmt(data.currents[i], 4)
        cells += _fmt(deg[i].reshape(-1), 4)
        if data.positions is not None:
            cells += _fmt(data.positions[i].reshape(-1), 7)
        if data.wrenches is not None:
            cells += [f"{v:.6g}" for v in data.wrenches[i].reshape(-1)]
        lines.append(",".join(cells))
    atomic_write_text(path, "\n".join(lines) + "\n")


def example_config(samples: int = 300, *, seed: int = 1) -> ExperimentConfig:
    """The experiment's settings of ``simulated_lab_data``: ``samples`` and ``seed``, the rest the
    defaults, but for the LSTMs' history and rollout steps at 1: only the simulation and the camera
    are used, so a short example (from 20 rows) is not refused for training spans it has no use for."""
    return ExperimentConfig(samples=samples, seed=seed, history=1, rollout_steps=1)


def simulated_lab_data(samples: int = 300, *, seed: int = 1, config: ExperimentConfig | None = None,
                       progress: Progress | None = None) -> LabData:
    """A short run of the simulated experiment as lab data: the perturbed real robot driven by the
    experiment's currents, read by the camera model (orientations and magnet positions). ``config``
    (None: ``example_config(samples, seed=seed)``) gives the settings. A run too large for this
    machine is refused first (``run.check_experiment_size``); ``progress`` as for
    ``simulate_manipulator`` (samples simulated)."""
    config = example_config(samples, seed=seed) if config is None else config
    check_experiment_size(config)
    spec = ManipulatorSpec()
    schedule = experiment_currents(spec, config)
    run = ManipulatorRun(dt=config.dt, n_samples=config.samples, settle=config.settle)
    traj = simulate_manipulator(config.robot_spec(spec), schedule, run, progress=progress)
    s_nodes = np.linspace(0.0, spec.length, spec.n_nodes)
    s_magnets = np.array([m.arc_length for m in spec.magnets])
    rng = np.random.default_rng([config.seed, 0x63616D])
    cam = camera_measure(np.asarray(traj.positions, np.float32).astype(np.float64), s_nodes, s_magnets,
                         config.camera_noise, rng, points=config.camera_points, degree=config.polynomial_degree)
    return LabData(time=np.asarray(traj.time, float), currents=np.asarray(traj.currents, float),
                   orientations=cam.orientations, positions=cam.positions, wrenches=None)


def write_example_csv(path, samples: int = 300, *, seed: int = 1, progress: Progress | None = None) -> LabData:
    """Write the example lab file (examples/magnetic_lab.csv): ``simulated_lab_data(samples, seed)``
    with currents, orientations and magnet positions; returns the data written. ``progress`` as
    for ``simulate_manipulator`` (samples simulated)."""
    data = simulated_lab_data(samples, seed=seed, progress=progress)
    config = example_config(samples, seed=seed)
    write_lab_csv(path, data, comment=(
        "softrnn magnetic lab data (docs/magnetic-format.md): a simulated example, not a measurement.\n"
        f"softrnn.experiments.magnetic.lab.write_example_csv(path, samples={samples}, seed={seed}): "
        "the perturbed 'real robot' "
        f"of the simulated experiment at {config.sample_rate:g} Hz,\n"
        "read by the camera model. time [s]; I0..I5 coil currents [A]; m{j}_rx,ry,rz rotation vector phi k [deg] "
        "(paper Sec. 5.2);\n"
        "m{j}_x,y,z magnet position [m]; magnet 0 proximal (s = L/2), magnet 1 distal (s = L - 1 mm)."))
    return data


# ----------------------------------------------------------------------------------------- comparison
def compare_lab(csv, config: ExperimentConfig | None = None, out_dir=None, *, progress: Progress | None = None,
                workers: int = 1, scheduler: str | None = None) -> dict:
    """The paper's comparison on a lab CSV: the static Cosserat model (nominal softrnn manipulator
    and coil layout, ``static_rod``) predicts the magnets' orientations from the currents; one LSTM
    per magnet (paper Fig. 11) trains on the first ``config.train_fraction`` of the samples and
    predicts the rest. Writes ``out_dir/table1.json``, ``out_dir/fig12.png`` and the two model
    folders; returns the table (``comparison.compare``) with ``source``, ``wrenches_from`` and
    ``assumptions`` added.

    The LSTMs' input II is the magnet wrench: the CSV's, or else computed from the currents, the
    nominal magnet moments along the measured tangents and the magnet positions (the CSV's, else
    the static model's). Without currents the static model is skipped (``cosserat`` is None).

    With ``config.calibrate`` (and currents at a constant interval), the dynamic model's stiffness,
    remanence and damping factors are also fitted to the first ``config.calibration_fraction`` of
    the training span (``run.calibrate_and_predict``; simulations on ``workers`` local processes or
    the Dask ``scheduler``), and the fitted model predicts the rest from the currents alone: the
    ``calibrated`` row, and ``calibration`` in the result.
    """
    config = ExperimentConfig() if config is None else config
    if not isinstance(config, ExperimentConfig):
        raise bad("config", type(config).__name__, "an ExperimentConfig")
    if out_dir is None:
        raise bad("out_dir", None, "an output folder")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise bad("out_dir", str(out), "a folder (it exists and is a file)")
    spec = ManipulatorSpec()
    data = read_lab_csv(csv, spec=spec)
    T = data.n_samples
    cut = int(math.floor(config.train_fraction * T))
    need = config.history + 4
    if min(cut, T - cut) < need:
        raise _fail(Path(csv), f"has {T} samples: the {100 * config.train_fraction:g} % training and the test span "
                               f"need at least history + 4 = {need} samples each; record more samples")
    calibration, calibrated = None, None
    if config.calibrate:
        dt = _constant_interval(Path(csv), data)
        calibration, calibrated = calibrate_and_predict(
            data.currents, data.orientations, data.positions, config, spec=spec, dt=dt, workers=workers,
            scheduler=scheduler, progress=progress)
    static = None
    if data.currents is not None:
        static = static_predictions(data.currents, spec=spec, n_steps=config.static_steps, tol=config.static_tol,
                                    position_tol=config.position_tol, max_failures=config.max_static_failures,
                                    progress=progress)
    if data.wrenches is not None:
        wrenches, source = data.wrenches, "the CSV's wrench columns"
    else:
        positions, source = data.positions, "the currents at the measured magnet positions"
        if positions is None:
            positions, source = _filled(static.positions), "the currents at the static model's magnet positions"
        wrenches = measured_wrenches(spec, data.currents, positions, tangents_from_rotation_vectors(data.orientations))
    dataset = orientation_dataset(data.time, data.orientations, wrenches, name=Path(csv).stem,
                                  extra={"source": str(csv)})
    static_info = None
    if static is not None:
        static_info = static_summary(static, config.static_steps, config.static_tol)
    result = compare(dataset, None if static is None else static.orientations, config, out, progress=progress,
                     static_info=static_info, figure_title=f"{Path(csv).name}: orientations over the test span",
                     calibrated_orientations=calibrated)
    result["calibration"] = calibration
    result["source"] = str(csv)
    result["wrenches_from"] = source
    result["assumptions"] = {
        "static_model": "softrnn's nominal manipulator and BigMag-like coil layout (magnetic.md defaults), in the "
                        "coils' frame (origin at the workspace centre, rod along +x, z up); a lab set-up with "
                        "other coils or rod needs those in ManipulatorSpec",
        "wrenches": f"input II from {source}",
        "orientation": "the CSV's rotation vectors phi k [deg] are the measurement the models are scored against",
    }


    atomic_write_text(out / "table1.json", json.dumps(result, indent=2, allow_nan=False) + "\n")
    return result


CALIBRATION_DT_SPREAD = 0.01
"""Largest relative deviation of a time step from the median step for ``--calibrate`` (the dynamic
model is driven by the currents at t = k dt)."""


def _constant_interval(path: Path, data: LabData) -> float:
    """The record's sample interval [s] for the calibration, or a one-line error: it needs currents
    and a constant interval."""
    if data.currents is None:
        raise _fail(path, "has no current columns I0..I5: --calibrate drives the dynamic model with the coil "
                          "currents; add them or leave out --calibrate")
    steps = np.diff(data.time)
    dt = float(np.median(steps))
    spread = float(np.max(np.abs(steps / dt - 1.0)))
    if spread > CALIBRATION_DT_SPREAD:
        raise _fail(path, f"has time steps up to {100 * spread:.1f} % off the median {dt:.6g} s: --calibrate needs "
                          f"samples at a constant interval (within {100 * CALIBRATION_DT_SPREAD:g} %); resample the "
                          f"record or leave out --calibrate")
    return dt


def _filled(positions: np.ndarray) -> np.ndarray:
    """Rows of NaN (failed static solves) replaced by the previous valid row (the first valid one
    for leading rows); (T, M, 3)."""
    p = np.array(positions, dtype=float)
    ok = np.all(np.isfinite(p), axis=(1, 2))
    if not ok.any():
        raise SoftrnnInputError("the static model failed on every sample, so the magnet positions for the wrenches "
                                "are unknown; add the m{j}_x, m{j}_y, m{j}_z columns or the wrench columns")
    idx = np.where(ok, np.arange(len(p)), -1)
    idx = np.maximum.accumulate(idx)
    idx[idx < 0] = int(np.argmax(ok))
    return p[idx]
