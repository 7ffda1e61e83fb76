"""The coil currents of the simulated experiment: minimum-norm currents for a smooth random field (paper section 5)."""

from __future__ import annotations

import math

import numpy as np

from ...magnetics.coils import unit_field_maps
from ...magnetics.manipulator import CurrentSchedule, ManipulatorSpec
from .config import ExperimentConfig


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
