"""The camera model of paper section 5.2: noisy centreline points, a polynomial fit P(s), the magnets' orientations.

A camera reconstructs the rod's centreline; a least-squares polynomial P(s) per coordinate smooths
it, and each magnet's orientation is read from the fit's tangent at the magnet's arc length s_m:

    phi_m = acos(z . unit(dP/ds(s_m))),   k_m = unit(z x dP/ds(s_m)),

reported as the rotation vector phi_m k_m [rad] (the rotation taking z to the tangent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import legendre

from ..errors import bad, is_int


@dataclass(frozen=True, eq=False)
class CameraMeasurement:
    """What the camera model reads at M magnets over T samples.

    Attributes
    ----------
    positions : (T, M, 3) [m]
        P(s_m) of the fitted polynomial
    tangents : (T, M, 3)
        unit dP/ds(s_m)
    orientations : (T, M, 3) [rad]
        rotation vectors phi_m k_m (``rotation_vectors``)
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


def _checked(positions, s_nodes, s_magnets, noise, points, degree) -> tuple:
    """``camera_measure``'s arguments as float arrays X (T, n, 3), s (n,), sm (M,) and the noise [m],
    or a ``SoftrnnInputError`` naming the bad one."""
    X = np.asarray(positions, dtype=np.float64)
    s = np.asarray(s_nodes, dtype=np.float64)
    sm = np.atleast_1d(np.asarray(s_magnets, dtype=np.float64))
    if X.ndim != 3 or X.shape[2] != 3 or X.shape[1] != s.shape[0] or s.ndim != 1 or s.shape[0] < 2:
        raise bad("positions", f"array of shape {X.shape}", f"(T, n, 3) with n = len(s_nodes) = {s.shape[0]} >= 2")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(s)) and np.all(np.diff(s) > 0)):
        raise bad("s_nodes", "non-increasing or non-finite values", "finite, strictly increasing arc lengths in m")
    if sm.ndim != 1 or np.any(sm < s[0]) or np.any(sm > s[-1]):
        raise bad("s_magnets", sm.tolist(), f"arc lengths in [{s[0]:g}, {s[-1]:g}] m")
    if not is_int(points) or not is_int(degree) or degree < 1 or points <= degree:
        raise bad("points, degree", (points, degree), "integers with points > degree >= 1")
    if isinstance(noise, bool) or not isinstance(noise, (int, float, np.integer, np.floating)) \
            or not math.isfinite(noise) or noise < 0:
        raise bad("noise", noise, "a finite number in [0, inf] m")
    return X, s, sm, float(noise)


def _sampled_points(X: np.ndarray, s: np.ndarray, sc: np.ndarray, noise: float, rng) -> np.ndarray:
    """The camera's points (T, P, 3) [m] at arc lengths sc (P,): linear interpolation of the nodes X
    (T, n, 3) [m] at arc lengths s (n,), plus Gaussian noise of standard deviation ``noise`` [m]."""
    j = np.clip(np.searchsorted(s, sc, side="right") - 1, 0, s.shape[0] - 2)      # (P,)
    f = (sc - s[j]) / (s[j + 1] - s[j])                                            # (P,)
    Y = (1.0 - f)[None, :, None] * X[:, j] + f[None, :, None] * X[:, j + 1]        # (T, P, 3)
    if noise > 0:
        Y = Y + rng.normal(0.0, noise, size=Y.shape)
    return Y


def _fit_at(Y: np.ndarray, sc: np.ndarray, sm: np.ndarray, lo: float, hi: float, degree: int) -> tuple:
    """Least-squares Legendre fit P(s) of degree ``degree`` on [lo, hi] to the points Y (T, P, 3) [m]
    at sc (P,); returns P(sm) (T, M, 3) [m] and the unit tangents dP/ds(sm) (T, M, 3)."""
    def scaled(a):
        return 2.0 * (a - lo) / (hi - lo) - 1.0

    T = Y.shape[0]
    V = legendre.legvander(scaled(sc), degree)                                     # (P, d+1)
    coef, *_ = np.linalg.lstsq(V, Y.transpose(1, 0, 2).reshape(len(sc), -1), rcond=None)  # (d+1, T*3)
    Vm = legendre.legvander(scaled(sm), degree)                                    # (M, d+1)
    dV = np.stack([legendre.legval(scaled(sm), legendre.legder(np.eye(degree + 1)[k]))
                   for k in range(degree + 1)], axis=-1)                           # (M, d+1) d/dx
    pos = (Vm @ coef).reshape(len(sm), T, 3).transpose(1, 0, 2)                    # (T, M, 3)
    d = (dV @ coef).reshape(len(sm), T, 3).transpose(1, 0, 2)                      # (T, M, 3)
    return pos, d / np.linalg.norm(d, axis=-1, keepdims=True)


def camera_measure(positions, s_nodes, s_magnets, noise: float, rng, *, points: int = 25,
                   degree: int = 5) -> CameraMeasurement:
    """The camera model: sample ``points`` centreline points evenly over [s_nodes[0], s_nodes[-1]]
    (linear between the nodes), add noise, fit P(s) of ``degree`` to each coordinate (least squares,
    Legendre basis on the scaled arc length), read the magnets.

    Parameters
    ----------
    positions, s_nodes : (T, n, 3) [m], (n,) [m]
        Centreline nodes of the rod (the real robot's, or any curve); their arc lengths, increasing.
    s_magnets : (M,) [m]
        Arc lengths of the magnets' centres (constant: the paper assumes no extension).
    noise : float
        Standard deviation [m] of the Gaussian noise (drawn from ``rng``) on every sampled coordinate.

    Returns
    -------
    CameraMeasurement
        The fitted positions, tangents and orientations at the magnets.
    """
    X, s, sm, noise = _checked(positions, s_nodes, s_magnets, noise, points, degree)
    sc = np.linspace(s[0], s[-1], int(points))                                     # (P,)
    Y = _sampled_points(X, s, sc, noise, rng)                                      # (T, P, 3)
    pos, tangents = _fit_at(Y, sc, sm, s[0], s[-1], int(degree))
    return CameraMeasurement(positions=pos, tangents=tangents, orientations=rotation_vectors(tangents))


def camera_orientations(positions, s_nodes, s_magnets, noise: float, rng, *, points: int = 25,
                        degree: int = 5) -> np.ndarray:
    """The magnets' measured orientations (T, M, 3) [rad] (rotation vectors phi_m k_m); see
    ``camera_measure`` for the arguments."""
    return camera_measure(positions, s_nodes, s_magnets, noise, rng, points=points, degree=degree).orientations
