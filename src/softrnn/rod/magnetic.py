"""Magnetic loads of a rod: point magnets embedded in it, in the field of point-dipole sources (coils)
whose currents follow a schedule (docs/magnetic.md §2.5).

``MagneticDipoles`` is one more load kind of a ``Setup`` (in ``Setup.loads``): the kernels evaluate
the field and gradient of the sources at every magnet from the current pose at every solver step,
in both integrators, and apply the force G mu and torque mu x B to the two nodes around each magnet
(``rod.magnetic_kernels._magnet_loads``). The currents are interpolated here, per step, into the kernels'
inputs (``source_currents``); the magnets' centres, rotations, fields, gradients and wrenches at the
saved steps come back as ``MagnetSamples`` (``Trajectory.magnets``).
"""

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ..errors import SimulationError, bad, store_frozen
from .kernels import MIN_DIPOLE_DISTANCE, magnet_wrench_into


@dataclass(frozen=True, eq=False)
class MagneticDipoles:
    """Point magnets in the rod and the dipole sources (coils) that act on them; M magnets, n_c
    sources, T schedule times.

    Attributes
    ----------
    nodes : (M,) int
        magnet j lies between nodes nodes[j] and nodes[j] + 1 (0-based, non-negative) ...
    fractions : (M,)
        ... at the fraction fractions[j] in [0, 1) of that segment
    moments : (M, 3)
        the magnets' moments in the body frame of that point [A m^2]
    source_positions : (n_c, 3)
        the sources' centres [m]
    source_moments : (n_c, 3)
        their moments per ampere [A m^2/A]
    times : (T,)
        increasing schedule times [s]
    currents : (T, n_c)
        the sources' currents at those times [A], linear in between, held outside
    """

    nodes: np.ndarray
    fractions: np.ndarray
    moments: np.ndarray
    source_positions: np.ndarray
    source_moments: np.ndarray
    times: np.ndarray
    currents: np.ndarray

    def __post_init__(self):
        nodes = np.array(self.nodes, dtype=np.int64).reshape(-1)
        M = nodes.size
        fields = {"nodes": nodes}
        for name, shape in (("fractions", (M,)), ("moments", (M, 3)), ("source_positions", (-1, 3)),
                            ("source_moments", (-1, 3)), ("times", (-1,))):
            a = np.array(getattr(self, name), dtype=float, order="C")
            if a.ndim != len(shape) or any(s not in (-1, d) for s, d in zip(shape, a.shape)) \
                    or not np.all(np.isfinite(a)):
                raise bad(f"magnetic.{name}", f"shape {a.shape}", f"finite values of shape {shape} (-1: any)")
            fields[name] = a
        n_c = fields["source_positions"].shape[0]
        cur = np.array(self.currents, dtype=float, order="C")
        times = fields["times"]
        if times.size < 1 or np.any(np.diff(times) <= 0):
            raise bad("magnetic.times", f"array of shape {times.shape}", "strictly increasing times in s")
        if cur.shape != (times.size, n_c) or not np.all(np.isfinite(cur)):
            raise bad("magnetic.currents", f"shape {cur.shape}", f"({times.size}, {n_c}) finite currents in A")
        if fields["source_moments"].shape != (n_c, 3):
            raise bad("magnetic.source_moments", f"shape {fields['source_moments'].shape}", f"({n_c}, 3)")
        if np.any(nodes < 0) or np.any((fields["fractions"] < 0) | (fields["fractions"] >= 1)):
            raise bad("magnetic.nodes", nodes.tolist(), "segment start nodes >= 0 with fractions in [0, 1)")
        fields["currents"] = cur
        store_frozen(self, **fields)

    @property
    def n_magnets(self) -> int:
        """Magnets M."""
        return self.nodes.size

    @property
    def n_sources(self) -> int:
        """Sources n_c."""
        return self.source_positions.shape[0]

    def with_currents(self, times, currents) -> "MagneticDipoles":
        """The same magnets and sources with another current schedule: times (T,) [s], currents (T, n_c) [A]."""
        return MagneticDipoles(nodes=self.nodes, fractions=self.fractions, moments=self.moments,
                               source_positions=self.source_positions, source_moments=self.source_moments,
                               times=times, currents=currents)

    def kernel_arrays(self, t: np.ndarray) -> dict:
        """The magnetic fields of ``kernels.StepInputs`` for the steps at times t (K,) [s], with
        the output buffers of no saved step (the scratch row only; ``buffers``)."""
        body = np.concatenate([self.fractions[:, None], self.moments], axis=1)
        return dict(magnet_node=self.nodes, magnet_body=body, source_positions=self.source_positions,
                     source_moments=self.source_moments,
                     source_currents=currents_into(np.ascontiguousarray(t, dtype=float), self.times, self.currents),
                     **self.buffers(0))

    def buffers(self, n_rows: int) -> dict:
        """Zeroed output buffers of ``StepInputs`` for ``n_rows`` saved steps and the scratch row."""
        M = self.n_magnets
        return dict(magnet_positions=np.zeros((n_rows + 1, M, 3)), magnet_rotations=np.zeros((n_rows + 1, M, 3, 3)),
                    magnet_fields=np.zeros((n_rows + 1, M, 3)), magnet_gradients=np.zeros((n_rows + 1, M, 3, 3)),
                    magnet_wrenches=np.zeros((n_rows + 1, M, 6)), magnet_failed=np.full(1, -1, dtype=np.int64))


class MagnetSamples(NamedTuple):
    """The sources' currents and the magnets' quantities at S saved samples (M magnets, n_c sources).

    Attributes
    ----------
    currents : (S, n_c)
        source currents [A]
    positions : (S, M, 3)
        magnet centres [m]
    rotations : (S, M, 3, 3)
        magnet rotations, body -> world
    fields : (S, M, 3)
        field at the magnets [T]
    gradients : (S, M, 3, 3)
        field gradient at the magnets [T/m]
    wrenches : (S, M, 6)
        force G mu [N] and torque mu x B [N m] on each magnet
    """

    currents: np.ndarray
    positions: np.ndarray
    rotations: np.ndarray
    fields: np.ndarray
    gradients: np.ndarray
    wrenches: np.ndarray


def magnet_samples(currents: np.ndarray, buffers: dict) -> MagnetSamples:
    """``MagnetSamples`` from the currents (S, n_c) [A] at the saved steps and the kernels' output
    ``buffers`` (``MagneticDipoles.buffers``, S + 1 rows: the scratch row dropped)."""
    return MagnetSamples(currents=currents, positions=buffers["magnet_positions"][:-1],
                         rotations=buffers["magnet_rotations"][:-1], fields=buffers["magnet_fields"][:-1],
                         gradients=buffers["magnet_gradients"][:-1], wrenches=buffers["magnet_wrenches"][:-1])


def concatenate(chunks: list) -> MagnetSamples:
    """One ``MagnetSamples`` from consecutive chunks."""
    return MagnetSamples(*(np.concatenate(parts) for parts in zip(*chunks)))


def start_wrench(R: np.ndarray, r: np.ndarray, inputs) -> np.ndarray:
    """The magnets' world force [N] and torque [N m] per node (n, 6) in the configuration R (n, 3, 3),
    r (n, 3) [m] at the first step of ``inputs``; a magnet too close to a source at the start
    raises ``SimulationError``."""
    wrench = np.zeros((len(r), 6))
    failed = magnet_wrench_into(R, r, inputs, wrench)
    if failed >= 0:
        raise SimulationError(f"magnet {failed} is within {MIN_DIPOLE_DISTANCE} m of a coil at the start; "
                              f"move the rod or the coils apart")
    return wrench


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def currents_at(t, times, values, j, out):
    """out (n,) <- currents at time t [s], linear in time between samples times (T,), values (T, n),
    held constant before the first and after the last; j is the search start (times[j] <= t) and the
    new start is returned, so increasing times cost O(1) each."""
    T = len(times)
    if t <= times[0] or T == 1:
        for k in range(len(out)):
            out[k] = values[0, k]
        return 0
    if t >= times[T - 1]:
        for k in range(len(out)):
            out[k] = values[T - 1, k]
        return T - 1
    if j < 0 or j >= T - 1 or times[j] > t:
        j = 0
    while times[j + 1] <= t:
        j += 1
    f = (t - times[j]) / (times[j + 1] - times[j])
    for k in range(len(out)):
        out[k] = (1.0 - f) * values[j, k] + f * values[j + 1, k]
    return j


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def _currents_rows(t, times, values, out):
    j = 0
    for i in range(len(t)):
        j = currents_at(t[i], times, values, j, out[i])


def currents_into(t: np.ndarray, times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Currents (K, n) [A] at times t (K,) [s] from the schedule times (T,), values (T, n)
    (``currents_at``, the interpolation the magnetic manipulator has always used)."""
    out = np.zeros((t.size, values.shape[1]))
    _currents_rows(t, times, values, out)
    return out
