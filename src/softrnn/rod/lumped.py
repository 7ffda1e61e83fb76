"""The rod's lumped arrays built once per setup into the frozen ``LumpedRod`` record that the
simulator and the batch simulator hand to the kernels (docs/lgvi.md §2.2, §2.6).

The record type lives in ``rod.kernel_records`` (see its module docstring for why) and is re-exported here.
Its arrays are contiguous float64 (``kind``: int64) private copies, made read-only.
"""

import numpy as np

from . import kernels
from .boundary import Clamp
from .discrete import segment_strains
from .kernels import LumpedRod

__all__ = ["constant_gravity", "frozen", "lumped_rod", "node_kinds", "with_damping"]


def _frozen_array(a, dtype) -> np.ndarray:
    out = np.array(a, dtype=dtype, order="C", copy=True)
    out.setflags(write=False)
    return out


def frozen(*, length: float, weight, mass, inertia, C1, C2, D1, D2, K0, G0, ct, cr, gravity, kind,
           kv_on: bool) -> LumpedRod:
    """A ``LumpedRod`` of read-only, contiguous float64 (``kind``: int64) copies of the arrays.

    Parameters
    ----------
    length : float
        Segment length l [m].
    weight, mass, ct, cr : array_like, (n,)
        Trapezoid weights [-], node masses [kg], translational [N s/m] and rotational [N m s] drag.
    inertia : array_like, (n, 3)
        Node inertias, body frame [kg m^2].
    C1, C2, D1, D2, K0, G0 : array_like, (n - 1, 3)
        Stiffnesses [N], [N m^2], Kelvin-Voigt coefficients [N s], [N m^2 s], stress-free strains
        [1/m], [-] per segment.
    gravity : array_like, (3,)
        Gravitational acceleration [m/s^2], world frame.
    kind : array_like of int, (n,)
        ``kernels.FREE``, ``CLAMPED`` or ``PINNED`` per node (``kv_on``: Kelvin-Voigt damping on).
    """
    f = np.float64
    return LumpedRod(
        length=float(length), weight=_frozen_array(weight, f), mass=_frozen_array(mass, f),
        inertia=_frozen_array(inertia, f), C1=_frozen_array(C1, f), C2=_frozen_array(C2, f),
        D1=_frozen_array(D1, f), D2=_frozen_array(D2, f), K0=_frozen_array(K0, f), G0=_frozen_array(G0, f),
        ct=_frozen_array(ct, f), cr=_frozen_array(cr, f), gravity=_frozen_array(gravity, f),
        kind=_frozen_array(kind, np.int64), kv_on=bool(kv_on))


def node_kinds(setup) -> np.ndarray:
    """Kind of every node of a ``Setup`` (n,) int64: FREE, or CLAMPED/PINNED from its boundary."""
    kind = np.zeros(setup.rod.n_nodes, dtype=np.int64)
    for bc in setup.boundary:
        kind[setup.node_index(bc.node)] = kernels.CLAMPED if isinstance(bc, Clamp) else kernels.PINNED
    return kind


def constant_gravity(setup) -> tuple:
    """The constant gravity (3,) [m/s^2] the lumped rod of a ``Setup`` carries: ``setup.gravity``
    when it is a constant, (0, 0, 0) when it is a time function (``rod.inputs.SetupInputs`` then
    applies m_a g(t) to every node as a tabulated nodal force)."""
    return (0.0, 0.0, 0.0) if callable(setup.gravity) else setup.gravity


def lumped_rod(setup) -> LumpedRod:
    """The lumped rod of a ``softrnn.rod.Setup``: masses, inertias, stiffnesses, stress-free strains
    of its reference shape, damping coefficients, constant gravity (``constant_gravity``) and node
    kinds (see ``LumpedRod``)."""
    rod = setup.rod
    l = rod.segment_length
    lump = rod.lumped()
    K0, G0 = segment_strains(setup.reference.rotations, setup.reference.positions, l)
    base = frozen(length=l, weight=lump["weight"], mass=lump["mass"], inertia=lump["inertia"], C1=lump["C1"],
                  C2=lump["C2"], D1=np.zeros_like(K0), D2=np.zeros_like(K0), K0=K0, G0=G0,
                  ct=np.zeros(rod.n_nodes), cr=np.zeros(rod.n_nodes), gravity=constant_gravity(setup),
                  kind=node_kinds(setup), kv_on=False)
    return with_damping(base, setup.damping)


def with_damping(rod: LumpedRod, damping) -> LumpedRod:
    """``rod`` with the coefficients of another ``softrnn.rod.Damping``: drag c w_a l per node and
    Kelvin-Voigt D = tau_d C per segment (docs/lgvi.md §2.6)."""
    wl = rod.weight * rod.length
    tau = damping.kelvin_voigt
    return rod._replace(ct=_frozen_array(damping.translational * wl, np.float64),
                        cr=_frozen_array(damping.rotational * wl, np.float64),
                        D1=_frozen_array(tau * rod.C1, np.float64), D2=_frozen_array(tau * rod.C2, np.float64),
                        kv_on=tau > 0)
