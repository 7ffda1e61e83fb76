"""Recordings of a simulated pneumatic-like soft arm, for ``softrnn lab benchmark`` without a scenario.

The arm: three chambers at 0°, 120° and 240° about its axis, each commanded a pressure p_i [bar] (0 to 1,
held for 1.5-6 s, reached by a ramp of 0.3-1.5 s, released to 0 a third of the time). Each chamber's
pressure follows its command through a first-order lag (``tau``) and a play of width ``play`` (the
friction of its walls): r_i. The bending vector b = sum r_i (cos a_i, sin a_i) bends the arm at a constant
curvature k |b| toward b, and the pressures lengthen it (``length`` + ``stretch`` sum r_i); the arm hangs
from its base along -z. Its tip follows that pose through a lightly damped swing (``swing_hz``, damping
ratio ``zeta``), and the recorded tip carries ``noise`` of marker noise per axis. Every session starts at
rest with its chambers empty; the sessions differ in their seeds alone.

    python examples/pneumatic_arm.py out/pneumatic --seeds 1 2 3
    softrnn lab benchmark --train out/pneumatic/session1.csv out/pneumatic/session2.csv \\
        --validate out/pneumatic/session3.csv --length 0.3 --families learned_map,sequence

Writes ``session<seed>.csv`` (``time``, ``tip_x``, ``tip_y``, ``tip_z`` [mm], ``act_p_a[bar]``,
``act_p_b[bar]``, ``act_p_c[bar]``) into the folder, each through a temporary name. About 8 s per
300 s session (the arm is integrated at 1 ms in Python).
"""

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class PneumaticArm:
    """The stand-in's parameters (SI units but the pressures, in bar)."""

    length: float = 0.3
    """Arm length at rest [m]."""
    stretch: float = 0.02
    """Lengthening per bar of every chamber's pressure [m/bar]."""
    curvature: float = 7.0
    """Curvature per bar of the bending vector [1/(m bar)]."""
    tau: float = 0.4
    """Each chamber's pressure lag [s]."""
    play: float = 0.06
    """Width of each chamber's play [bar]."""
    swing_hz: float = 1.1
    """Natural frequency of the tip's swing [Hz]."""
    zeta: float = 0.08
    """Damping ratio of the swing."""
    noise: float = 3e-4
    """Marker noise per axis [m]."""

    def pose(self, r: np.ndarray) -> np.ndarray:
        """(3,) [m] the tip of the arm at rest under the chambers' effective pressures ``r`` (3,) [bar]."""
        angles = np.deg2rad([0.0, 120.0, 240.0])
        bx, by = float(r @ np.cos(angles)), float(r @ np.sin(angles))
        kappa = self.curvature * np.hypot(bx, by) + 1e-9
        s = self.length + self.stretch * float(r.sum())
        phi = np.arctan2(by, bx)
        radial = (1.0 - np.cos(kappa * s)) / kappa
        return np.array([radial * np.cos(phi), radial * np.sin(phi), -np.sin(kappa * s) / kappa])


def commands(rng: np.random.Generator, duration: float, dt: float) -> np.ndarray:
    """(T, 3) [bar] each chamber's command at every step of ``dt`` [s] over ``duration`` [s]."""
    n = int(round(duration / dt))
    p = np.zeros((n, 3))
    for c in range(3):
        t, now = 0.0, 0.0
        while t < duration:
            ramp, hold = rng.uniform(0.3, 1.5), rng.uniform(1.5, 6.0)
            target = 0.0 if rng.random() < 0.3 else rng.uniform(0.0, 1.0)
            a, b, e = (min(n, int(round(x / dt))) for x in (t, t + ramp, t + ramp + hold))
            p[a:b, c] = now + (target - now) * np.linspace(0.0, 1.0, b - a, endpoint=False)
            p[b:e, c] = target
            now, t = target, t + ramp + hold
    return p


def run(arm: PneumaticArm, p: np.ndarray, dt: float = 1e-3) -> np.ndarray:
    """(T, 3) [m] the tip (without marker noise) at each step of ``dt`` [s] under the commands ``p`` (T, 3)
    [bar], from rest with the chambers empty: each row's tip before that row's command acts
    (semi-implicit Euler)."""
    q, r = np.zeros(3), np.zeros(3)
    x, v = arm.pose(r), np.zeros(3)
    omega = 2.0 * np.pi * arm.swing_hz
    tips = np.empty((len(p), 3))
    for i in range(len(p)):
        tips[i] = x
        q += dt * (p[i] - q) / arm.tau
        r = np.clip(r, q - arm.play / 2.0, q + arm.play / 2.0)
        v += dt * (omega ** 2 * (arm.pose(r) - x) - 2.0 * arm.zeta * omega * v)
        x = x + dt * v
    return tips


def session(arm: PneumaticArm, seed: int, duration: float = 300.0, rate: float = 20.0,
            dt: float = 1e-3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One session: (time (T,) [s], tip (T, 3) [m] with marker noise, commands (T, 3) [bar]) sampled at
    ``rate`` [Hz], the arm integrated at ``dt`` [s] (``run``)."""
    rng = np.random.default_rng(seed)
    p = commands(rng, duration, dt)
    rows = np.arange(0, len(p), int(round(1.0 / (rate * dt))))
    tips = run(arm, p, dt)[rows] + rng.normal(0.0, arm.noise, (len(rows), 3))
    return rows * dt, tips, p[rows]


def csv_text(time: np.ndarray, tip: np.ndarray, p: np.ndarray) -> str:
    """A session as the lab recording CSV (tip in mm, pressures in bar)."""
    lines = ["# simulated pneumatic-like soft arm (examples/pneumatic_arm.py)",
             "time,tip_x,tip_y,tip_z,act_p_a[bar],act_p_b[bar],act_p_c[bar]"]
    lines += [f"{t:.4f}," + ",".join(f"{v * 1e3:.4f}" for v in x) + "," + ",".join(f"{v:.4f}" for v in u)
              for t, x, u in zip(time, tip, p)]
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="folder for the sessions' CSV files")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3], help="one session per seed")
    ap.add_argument("--duration", type=float, default=300.0, help="each session's length [s]")
    ap.add_argument("--rate", type=float, default=20.0, help="rows per second [Hz]")
    args = ap.parse_args()
    bad = ([f"--duration={args.duration:g} is invalid: a positive length in s"] * (args.duration <= 0)
           + [f"--rate={args.rate:g} is invalid: rows per second in (0, 1000] Hz (the arm is integrated at 1 ms)"]
           * (not 0 < args.rate <= 1000) + [f"--seeds={s} is invalid: seeds >= 0" for s in args.seeds if s < 0])
    if bad:
        ap.exit(2, f"pneumatic_arm.py: {bad[0]}\n")
    args.out.mkdir(parents=True, exist_ok=True)
    for seed in args.seeds:
        path = args.out / f"session{seed}.csv"
        tmp = path.with_suffix(".tmp")
        tmp.write_text(csv_text(*session(PneumaticArm(), seed, args.duration, args.rate)))
        tmp.replace(path)
        print(f"pneumatic arm: wrote {path}")


if __name__ == "__main__":
    main()
