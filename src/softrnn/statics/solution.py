"""What a static solve returns: its ``Status`` and the ``StaticSolution`` (shape, internal
wrenches, base wrench, tendon tensions), with the one-line message of each outcome."""

import enum
from dataclasses import dataclass, field

import numpy as np

from ..errors import SimulationError
from ..rod.so3 import quaternion_to_matrix
from . import kernels

NO_TENSIONS = np.zeros(0)
"""The (0,) tendon tensions and shortenings of a rod without tendons (read-only)."""
NO_TENSIONS.setflags(write=False)


class Status(enum.Enum):
    """Outcome of a static solve."""

    CONVERGED = kernels.CONVERGED
    ITERATION_LIMIT = kernels.ITERATION_LIMIT
    SINGULAR = kernels.SINGULAR
    NOT_FINITE = kernels.NOT_FINITE


@dataclass(frozen=True, eq=False)
class StaticSolution:
    """Result of a static solve.

    Attributes
    ----------
    status : Status
        CONVERGED only when residual <= tol
    message : str
        one line: what happened and how to fix it
    iterations : int
        Levenberg-Marquardt iterations
    residual : float
        |[n(L+), m(L+)]|_2 of the tip wrench [N, N m mixed, as the paper]
    tol : float
        the tolerance E it was solved to
    integrations : int
        RK4 integrations of the rod (Jacobians included)
    s : (N + 1,)
        grid arc lengths [m]
    positions : (N + 1, 3)
        centreline [m], world frame
    quaternions : (N + 1, 4)
        unit, scalar first, body -> world
    n : (N + 1, 3)
        internal force [N], world frame, on the base side of each grid point (with tendons: the
        section's total, rod plus tendons)
    m : (N + 1, 3)
        internal moment [N m], world frame, likewise
    base_wrench : (6,)
        [n(0), m(0)]: the load the rod puts on its base (the clamp's reaction on the rod is
        -base_wrench); a warm-start guess
    tendon_tensions : (m,)
        the tensions [N] of the rod's m tendons in this solution (given, or solved for the tendons
        driven by a displacement)
    tendon_shortening : (m,)
        l_0 - l [m]: how much each tendon's path along the rod is shorter than on the stress-free
        rod (bending toward it, compression)
    """

    status: Status
    message: str
    iterations: int
    residual: float
    tol: float
    integrations: int
    s: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    n: np.ndarray
    m: np.ndarray
    base_wrench: np.ndarray
    tendon_tensions: np.ndarray = field(default_factory=lambda: NO_TENSIONS)
    tendon_shortening: np.ndarray = field(default_factory=lambda: NO_TENSIONS)

    @property
    def converged(self) -> bool:
        """True when the solve met its tolerance (``status`` is ``Status.CONVERGED``)."""
        return self.status is Status.CONVERGED

    @property
    def rotations(self) -> np.ndarray:
        """Rotation matrices (N + 1, 3, 3), body -> world (columns d1, d2, d3)."""
        return quaternion_to_matrix(self.quaternions)

    @property
    def tip_position(self) -> np.ndarray:
        """positions[-1] (3,) [m]."""
        return self.positions[-1]

    def index(self, s: float) -> int:
        """Grid point nearest to the arc length s [m] (load points and magnets are grid points)."""
        return int(np.argmin(np.abs(self.s - s)))

    def raise_for_status(self) -> "StaticSolution":
        """Return self if converged, else raise ``SimulationError`` with the one-line message."""
        if self.status is not Status.CONVERGED:
            raise SimulationError(f"static solve {self.status.name.lower()}: {self.message}")
        return self


def outcome_message(status: Status, residual: float, tol: float, iterations: int, max_iter: int) -> str:
    """The one-line message of a solve that ended in ``status``: what happened and how to fix it."""
    res = f"tip wrench residual {residual:.3g}"
    if status is Status.CONVERGED:
        return f"converged: {res} <= tol {tol:.3g} after {iterations} iteration{'s' if iterations != 1 else ''}"
    if status is Status.ITERATION_LIMIT:
        return (f"no convergence in max_iter={max_iter} iterations ({res} > tol {tol:.3g}); raise max_iter, "
                "start from a closer guess (e.g. a previous solution's base_wrench) or apply the load in steps")
    if status is Status.SINGULAR:
        return (f"the Levenberg-Marquardt step stalled ({res} > tol {tol:.3g} after {iterations} iterations: "
                "singular shooting Jacobian or a tolerance below round-off); loosen tol, start from a closer "
                "guess or apply the load in smaller steps")
    return (f"the rod integration overflowed to non-finite values ({res}); check that the loads, the field "
            "and the guess are physically sized (N, N m, T) for this rod")
