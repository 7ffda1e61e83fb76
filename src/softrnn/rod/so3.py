"""Rotation helpers in NumPy: Cayley map (docs/lgvi.md §2.2), quaternions, axis rotations.

Quaternions are scalar-first unit quaternions ``[w, x, y, z]``; rotation matrices map body to
world (columns are the directors d1, d2, d3). All functions accept stacked inputs (..., 3).
"""

import numpy as np


def hat(x: np.ndarray) -> np.ndarray:
    """Skew matrix of x (..., 3) -> (..., 3, 3) with hat(x) @ y = cross(x, y)."""
    x = np.asarray(x, dtype=float)
    z = np.zeros(x.shape[:-1])
    return np.stack(
        [np.stack([z, -x[..., 2], x[..., 1]], -1),
         np.stack([x[..., 2], z, -x[..., 0]], -1),
         np.stack([-x[..., 1], x[..., 0], z], -1)], -2)


def cay(x: np.ndarray) -> np.ndarray:
    """Cayley map R^3 -> SO(3): I + 4/(4+|x|^2) (x^ + x^2/2); rotates by 2 atan(|x|/2)."""
    x = np.asarray(x, dtype=float)
    X = hat(x)
    a = 4.0 / (4.0 + np.sum(x * x, axis=-1))[..., None, None]
    return np.eye(3) + a * (X + 0.5 * X @ X)


def cay_inv(Q: np.ndarray) -> np.ndarray:
    """Inverse Cayley map SO(3) -> R^3 for rotation angles below pi."""
    Q = np.asarray(Q, dtype=float)
    s = 2.0 / (1.0 + np.trace(Q, axis1=-2, axis2=-1))
    A = Q - np.swapaxes(Q, -1, -2)
    return s[..., None] * np.stack([A[..., 2, 1], A[..., 0, 2], A[..., 1, 0]], -1)


def dcay_inv(x: np.ndarray) -> np.ndarray:
    """Inverse right-trivialised tangent of cay: I - x^/2 + x x^T / 4, (..., 3) -> (..., 3, 3)."""
    x = np.asarray(x, dtype=float)
    return np.eye(3) - 0.5 * hat(x) + 0.25 * x[..., :, None] * x[..., None, :]


def axis_rotation(axis: str, angle: float | np.ndarray) -> np.ndarray:
    """Rotation by ``angle`` radians about the world axis 'x', 'y' or 'z'."""
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(angle), np.zeros_like(angle)
    rows = {
        "x": [[o, z, z], [z, c, -s], [z, s, c]],
        "y": [[c, z, s], [z, o, z], [-s, z, c]],
        "z": [[c, -s, z], [s, c, z], [z, z, o]],
    }[axis]
    return np.stack([np.stack(row, -1) for row in rows], -2)


def matrix_to_quaternion(R: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) -> unit quaternions (..., 4), scalar first, w >= 0."""
    R = np.asarray(R, dtype=float)
    m = R.reshape(-1, 3, 3)
    tr = np.trace(m, axis1=1, axis2=2)
    cand = np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], -1)
    k = np.argmax(cand, axis=1)
    q = np.empty((m.shape[0], 4))
    for case in range(4):
        sel = k == case
        if not np.any(sel):
            continue
        s = m[sel]
        if case == 0:
            t = np.sqrt(1.0 + tr[sel]) * 2.0
            q[sel] = np.stack([0.25 * t, (s[:, 2, 1] - s[:, 1, 2]) / t, (s[:, 0, 2] - s[:, 2, 0]) / t,
                               (s[:, 1, 0] - s[:, 0, 1]) / t], -1)
        else:
            i = case - 1
            j, l = (i + 1) % 3, (i + 2) % 3
            t = np.sqrt(1.0 + s[:, i, i] - s[:, j, j] - s[:, l, l]) * 2.0
            qi = np.empty((s.shape[0], 4))
            qi[:, 0] = (s[:, l, j] - s[:, j, l]) / t
            qi[:, 1 + i] = 0.25 * t
            qi[:, 1 + j] = (s[:, j, i] + s[:, i, j]) / t
            qi[:, 1 + l] = (s[:, l, i] + s[:, i, l]) / t
            q[sel] = qi
    q *= np.where(q[:, :1] < 0.0, -1.0, 1.0)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q.reshape(R.shape[:-2] + (4,))


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4), scalar first -> rotation matrices (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def frame_from_tangent(tangent: np.ndarray, normal_hint: np.ndarray) -> np.ndarray:
    """Right-handed frames with d3 = tangent and d1 the part of ``normal_hint`` normal to it.

    tangent (..., 3), normal_hint (..., 3) -> (..., 3, 3) with columns d1, d2, d3.
    """
    t = np.asarray(tangent, dtype=float)
    t = t / np.linalg.norm(t, axis=-1, keepdims=True)
    n = np.broadcast_to(np.asarray(normal_hint, dtype=float), t.shape)
    d1 = n - np.sum(n * t, axis=-1, keepdims=True) * t
    d1 = d1 / np.linalg.norm(d1, axis=-1, keepdims=True)
    d2 = np.cross(t, d1)
    return np.stack([d1, d2, t], axis=-1)
