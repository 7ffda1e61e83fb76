"""Reference trajectories of the distal magnet's orientation for the closed loop: its bending angle
(the orientation about y, the large one) and its out-of-plane angle (about x), both in the form the
camera reports (the components of the rotation vector phi k taking z to the magnet's tangent).

A ``Reference`` holds target angles at the frame times; the shipped ones are centred on the rod's
rest pose under no field and stay inside what the coils reach (``REST_DEG``, ``SPAN_DEG``):

* ``step``: a staircase of bending targets held 5 s each;
* ``sine``: bending angle sin(2 pi 0.2 t), out-of-plane angle a quarter period behind;
* ``random``: a smooth random trajectory (sums of sinusoids, 0.02-0.3 Hz) of both angles;
* a CSV file: ``time,about_y_deg,about_x_deg`` (header first; time from 0, strictly increasing),
  interpolated linearly at the frame times and held after its last row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError, bad
from ..io.csv_table import read_csv_lines, shown

REFERENCES = ("step", "sine", "random")
"""The shipped references (``reference(name, ...)``); a path to a CSV is the user's own."""

REST_DEG = (0.0, 97.0)
"""(about x, about y) [deg]: the distal magnet's orientation near rest (the rod sags under gravity
and the magnets' weight: 90 deg is horizontal)."""

SPAN_DEG = (4.0, 15.0)
"""Largest excursion (about x, about y) [deg] of the shipped references from ``REST_DEG``: inside
what the coils reach with the field's magnitude fixed (the nominal static model holds the distal
magnet from about 62 to 113 deg about y; with the field pointing further down, below about -35 deg
elevation, the planar pose is no longer a static solution and the robot flips out of plane)."""

CSV_COLUMNS = ("time", "about_y_deg", "about_x_deg")


@dataclass(frozen=True, eq=False)
class Reference:
    """Target orientation of the distal magnet at the frame times."""

    name: str
    """The reference's name."""
    times: np.ndarray
    """The frame times (K,) [s] from 0."""
    angles: np.ndarray
    """The targets (K, 2) [rad]: columns (about x, about y) as the camera reports them."""

    def __post_init__(self):
        t = np.asarray(self.times, dtype=np.float64)
        a = np.asarray(self.angles, dtype=np.float64)
        if t.ndim != 1 or a.shape != (t.size, 2) or not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
            raise bad("reference", f"times {t.shape}, angles {a.shape}", "finite times (K,) and angles (K, 2)")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "angles", a)

    def window(self, k: int, horizon: int) -> np.ndarray:
        """Targets (horizon, 2) [rad] of frames k + 1 .. k + horizon (the last one held past the end)."""
        idx = np.minimum(np.arange(k + 1, k + 1 + horizon), self.times.size - 1)
        return self.angles[idx]


def _frames(duration: float, rate: float) -> np.ndarray:
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise bad("--duration", duration, "a positive number of seconds")
    return np.arange(int(round(duration * rate)) + 1) / rate


def reference(name_or_path, *, duration: float = 60.0, rate: float = 30.0, seed: int = 0) -> Reference:
    """A shipped reference by name (``REFERENCES``) or a CSV file, at ``rate`` [Hz] over ``duration`` [s]."""
    t = _frames(duration, rate)
    rest = np.radians(REST_DEG)
    span = np.radians(SPAN_DEG)
    name = str(name_or_path)
    if name == "step":
        levels = np.array([0.0, 0.6, -0.6, 1.0, -1.0, 0.3, -0.3, 0.8, -0.8, 0.0, 0.5, -0.5, 0.0])
        level = levels[np.minimum((t // 5.0).astype(int), levels.size - 1)]
        angles = np.stack([np.full_like(t, rest[0]), rest[1] + span[1] * level], 1)
    elif name == "sine":
        w = 2 * math.pi * 0.2
        angles = np.stack([rest[0] + 0.5 * span[0] * np.sin(w * t - 0.5 * math.pi) + 0.5 * span[0],
                           rest[1] + span[1] * np.sin(w * t)], 1)
    elif name == "random":
        angles = _random(t, rate, seed, rest, span)
    else:
        return _csv_reference(Path(name), t)
    return Reference(name=name, times=t, angles=angles)


RANDOM_SCALE_S = 600.0
"""The random reference is scaled to its span over its first ``RANDOM_SCALE_S`` seconds (or its
whole duration if longer), so a shorter run follows the start of a longer one exactly."""


def _random(t: np.ndarray, rate: float, seed: int, rest: np.ndarray, span: np.ndarray) -> np.ndarray:
    """(K, 2) [rad]: per angle, five sines of random frequency (0.02-0.3 Hz) and phase, from rest at t = 0."""
    rng = np.random.default_rng([seed, 0x726566])
    grid = np.arange(int(round(max(RANDOM_SCALE_S, t[-1]) * rate)) + 1) / rate
    cols = []
    for c in range(2):
        f = np.exp(rng.uniform(math.log(0.02), math.log(0.3), 5))
        ph = rng.uniform(0, 2 * math.pi, 5)
        s, scale = (_waves(f, ph, times) for times in (t, grid))
        cols.append(rest[c] + span[c] * s / max(float(np.max(np.abs(scale))), 1e-12))
    return np.stack(cols, 1)


def _waves(f: np.ndarray, ph: np.ndarray, t: np.ndarray) -> np.ndarray:
    """sum_i sin(2 pi f_i t + ph_i), minus its value at t = 0 (a start at rest)."""
    return np.sin(2 * math.pi * f[None] * t[:, None] + ph[None]).sum(1) - np.sin(ph).sum()


def _csv_rows(path: Path) -> tuple[list[int], np.ndarray]:
    """The line numbers and values (K, 3) of a reference CSV's rows, after its header; a one-line
    ``SoftrnnInputError`` naming the file for an unreadable, binary, empty or ragged file, a header
    other than ``CSV_COLUMNS`` or a cell that is not a finite number."""
    header = ",".join(CSV_COLUMNS)
    lines = read_csv_lines(path, f"the header {header} (time [s], target angles about y and about x [deg])",
                           SoftrnnInputError, what="the reference")
    number, first = lines[0]
    if tuple(c.strip().lower() for c in first.split(",")) != CSV_COLUMNS:
        raise SoftrnnInputError(f"{path}: the header must be {header} (time [s], target angles about y and about "
                                f"x [deg]); line {number} is {shown(first, 60)}")
    rows = []
    for number, line in lines[1:]:
        try:
            values = [float(p) for p in line.split(",")]
        except ValueError:
            values = []
        if len(values) != 3 or not all(math.isfinite(v) for v in values):
            raise SoftrnnInputError(f"{path}: line {number}: expected 3 finite numbers ({header}), got "
                                    f"{shown(line, 60)}")
        rows.append(values)
    return [n for n, _ in lines[1:]], np.array(rows, dtype=np.float64).reshape(-1, 3)


def _csv_reference(path: Path, t: np.ndarray) -> Reference:
    if path.suffix.lower() != ".csv":
        raise bad("--reference", str(path), f"one of {', '.join(REFERENCES)}, or a .csv file "
                                            f"({','.join(CSV_COLUMNS)})")
    if not path.exists():
        raise bad("--reference", str(path), "an existing .csv file (no such file)")
    if path.is_dir():
        raise bad("--reference", str(path), "a .csv file, but it is a folder")
    numbers, data = _csv_rows(path)
    rule = "the times must start at 0 and increase strictly (at least 2 rows)"
    if data.shape[0] < 2:
        raise SoftrnnInputError(f"{path}: has {data.shape[0]} data row{'s' if data.shape[0] != 1 else ''}; {rule}")
    if data[0, 0] != 0.0:
        raise SoftrnnInputError(f"{path}: line {numbers[0]}: the first time is {float(data[0, 0])!r}; {rule}")
    steps = np.diff(data[:, 0])
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        raise SoftrnnInputError(f"{path}: line {numbers[i + 1]}: time {float(data[i + 1, 0])!r} is not after "
                                f"{float(data[i, 0])!r} (line {numbers[i]}); {rule}: sort the rows and drop "
                                "duplicated ones")
    angles = np.stack([np.interp(t, data[:, 0], np.radians(data[:, 2])),
                       np.interp(t, data[:, 0], np.radians(data[:, 1]))], 1)
    return Reference(name=path.stem, times=t, angles=angles)
