"""The LSTMs' data of the magnetic experiment (paper Data-set IV): measured orientations and the magnets' wrenches."""

from __future__ import annotations

import numpy as np

from ...errors import bad
from ...io.reader import Dataset
from ...magnetics.coils import unit_field_maps
from ...magnetics.magnets import wrench as magnet_wrench
from ...magnetics.manipulator import ManipulatorSpec


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


def orientation_dataset(time_s, orientations, wrenches, *, name: str = "magnetic-experiment",
                        extra: dict | None = None):
    """The paper's Data-set IV in memory: a ``softrnn.io.Dataset`` whose two 'nodes' are the magnets
    (0 proximal, 1 distal), whose positions hold their measured orientations (rotation vectors
    (T, 2, 3) [rad]) and whose forces and torques hold their wrenches (T, 2, 6) [N, N m]. The
    quaternions are identity placeholders (``has_orientations`` False)."""
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

