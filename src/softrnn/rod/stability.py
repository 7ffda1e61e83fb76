"""Largest stable step of the explicit elastic update (docs/lgvi.md §3).

omega_max^2 ~ max(4 E/(rho l^2), 4 G/(rho r^2) + 4 G/(rho l^2)) for a uniform rod, generalised
here per segment to lumped stiffness and mass so that overrides (magnets) are covered.
Kelvin-Voigt damping with retardation time tau adds h <= sqrt(tau^2 + 4/omega^2) - tau.
"""

import numpy as np

# 0.5 of 2/omega_max: an undamped 15-node cantilever whipping down under gravity diverged at 0.6
# (the notes suggest 0.6) and ran at 0.5; divergence is always detected and reported anyway.
DEFAULT_SAFETY = 0.5


def omega_max(lumped: dict, seg_length: float) -> float:
    """Estimated highest angular frequency [rad/s] of the lumped, linearised rod."""
    w = lumped["weight"]
    m = lumped["mass"] / w
    J = lumped["inertia"] / w[:, None]
    m_s = np.minimum(m[:-1], m[1:])
    J_s = np.minimum(J[:-1], J[1:])
    l = seg_length
    C1, C2 = lumped["C1"], lumped["C2"]
    axial = 4.0 * C1[:, 2] / (l * m_s)
    bending = 4.0 * C2[:, 0] / (l * J_s[:, 0])
    twist = 4.0 * C2[:, 2] / (l * J_s[:, 2])
    shear = C1[:, 0] * l / J_s[:, 0] + 4.0 * C1[:, 0] / (l * m_s)
    return float(np.sqrt(np.max(np.concatenate([axial, bending, twist, shear]))))


def stable_step(lumped: dict, seg_length: float, kelvin_voigt: float = 0.0,
                safety: float = DEFAULT_SAFETY) -> float:
    """Largest step h [s] the integrator accepts: safety * min(2/omega_max, Kelvin-Voigt limit)."""
    om = omega_max(lumped, seg_length)
    h = 2.0 / om
    if kelvin_voigt > 0:
        h = min(h, np.sqrt(kelvin_voigt**2 + 4.0 / om**2) - kelvin_voigt)
    return safety * h
