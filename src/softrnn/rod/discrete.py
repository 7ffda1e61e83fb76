"""Discrete strains, strain energy and internal loads in NumPy (docs/lgvi.md §2.2-2.4).

The reference implementation of what the numba kernel computes: used for stress-free reference
strains, energy diagnostics and the gradient test of the kernel's loads.
"""

import numpy as np

from .so3 import cay_inv


def segment_strains(rotations: np.ndarray, positions: np.ndarray, seg_length: float):
    """SE(3)-Cayley strains of each segment.

    rotations (n, 3, 3), positions (n, 3) [m] -> K (n-1, 3) [1/m] (curvature/twist),
    Gamma (n-1, 3) [-] (shear/stretch), both in the frame of the segment's first node.
    """
    R, r = np.asarray(rotations, float), np.asarray(positions, float)
    Q = np.swapaxes(R[:-1], 1, 2) @ R[1:]
    p = np.einsum("aji,aj->ai", R[:-1], r[1:] - r[:-1])
    x = cay_inv(Q)
    u = p - 0.5 * np.cross(x, p)
    return x / seg_length, u / seg_length


def strain_energy(rotations, positions, seg_length, C1, C2, K0, G0) -> float:
    """``U = sum_b l [ (G-G0).C1(G-G0)/2 + (K-K0).C2(K-K0)/2 ]`` [J]."""
    K, G = segment_strains(rotations, positions, seg_length)
    eg, ek = G - G0, K - K0
    return float(0.5 * seg_length * np.sum(C1 * eg * eg + C2 * ek * ek))


def internal_loads(rotations, positions, seg_length, C1, C2, K0, G0, tendon_terms=None):
    """Closed-form internal loads of §2.4: f (n, 3) [N] world frame, t (n, 3) [N m] body frame.

    f_a = -dU/dr_a and t_a = -(left-trivialised) dU/dLambda_a. ``tendon_terms``: a function
    (K, Gamma) -> (dN, dM) (n - 1, 3) added to the segments' resultants (the tendons' active stress,
    ``rod.tendons.tendon_resultants``), or None.
    """
    R, r = np.asarray(rotations, float), np.asarray(positions, float)
    l = seg_length
    Q = np.swapaxes(R[:-1], 1, 2) @ R[1:]
    p = np.einsum("aji,aj->ai", R[:-1], r[1:] - r[:-1])
    x = cay_inv(Q)
    u = p - 0.5 * np.cross(x, p)
    N = C1 * (u / l - G0)
    M = C2 * (x / l - K0)
    if tendon_terms is not None:
        dN, dM = tendon_terms(x / l, u / l)
        N = N + dN
        M = M + dM
    c = N + 0.5 * np.cross(x, N)
    T = M + 0.5 * np.cross(x, M) + 0.25 * x * np.sum(x * M, axis=1, keepdims=True) + 0.5 * np.cross(u, c)
    nsp = np.einsum("aij,aj->ai", R[:-1], c)
    Tp = np.einsum("aji,aj->ai", Q, T - np.cross(p, c))
    n = r.shape[0]
    f = np.zeros((n, 3))
    t = np.zeros((n, 3))
    f[:-1] += nsp
    f[1:] -= nsp
    t[:-1] += T
    t[1:] -= Tp
    return f, t
