"""Status codes of the stepping kernels (``rod.kernels``, ``rod.implicit``) with what each
means and how to fix it; ``raise_for_status`` turns a failed kernel call into a one-line
``SimulationError``, as ``statics.solver.Status`` does for the static solver."""

from enum import IntEnum

from ..errors import SimulationError
from . import implicit, kernels


class KernelStatus(IntEnum):
    """What a kernel call returned; the values are the integer codes of ``rod.kernels``."""

    OK = kernels.OK
    DIVERGED = kernels.DIVERGED
    NEWTON_FAILED = kernels.NEWTON_FAILED
    SINGULAR = implicit.SINGULAR
    MAGNET_TOO_CLOSE = kernels.MAGNET_TOO_CLOSE

    @property
    def fixes(self) -> tuple[str, ...]:
        """The remedies, each one a phrase that follows "use"/"add"/..., most effective first."""
        return _FIXES[self]


_FIXES = {
    KernelStatus.OK: (),
    KernelStatus.DIVERGED: ("use more substeps (a smaller safety factor)", "add damping"),
    KernelStatus.NEWTON_FAILED: ("use more substeps",),
    KernelStatus.SINGULAR: ("give every node a mass (density > 0) and the rod a stiffness",),
    KernelStatus.MAGNET_TOO_CLOSE: ("lower the currents", "move the coils out"),
}


def _or(phrases) -> str:
    """'a', 'a or b', 'a, b or c'."""
    phrases = list(phrases)
    return phrases[0] if len(phrases) == 1 else ", ".join(phrases[:-1]) + " or " + phrases[-1]


def status_message(code: int, *, step: int, t0: float, h: float, magnet: int = -1, min_distance: float = 0.0,
                   more_fixes: tuple = ()) -> str:
    """One line (returned) for a failed kernel call: what happened, when, and how to fix it.

    Parameters
    ----------
    step : int
        Index of the failed step; it began at t = t0 + step h.
    t0, h : float
        Time of step 0 and the solver step [s].
    magnet, min_distance : int, float
        For MAGNET_TOO_CLOSE: the magnet's index, and the smallest allowed distance to a source [m].
    more_fixes : tuple of str
        Remedies that the caller's context adds after the status's own (e.g. "lower the currents").
    """
    status = KernelStatus(code)
    t = t0 + step * h
    when = f"at t = {t:.6g} s (step {step}, h = {h:.3g} s)"
    if status is KernelStatus.DIVERGED:
        what = (f"the simulation diverged {when}: a node moved more than a segment or rotated more than "
                f"~28 deg in one step")
    elif status is KernelStatus.NEWTON_FAILED:
        what = f"the rotation Newton solve failed {when}"
    elif status is KernelStatus.SINGULAR:
        what = f"the implicit step's linear system was singular {when}"
    elif status is KernelStatus.MAGNET_TOO_CLOSE:
        what = f"magnet {magnet} came within {min_distance} m of a coil at t = {t:.6g} s"
    else:
        raise ValueError(f"code={code!r} is invalid: a failure status, not {status.name}")
    fixes = dict.fromkeys(status.fixes + tuple(more_fixes))  # in order, without repeats
    return f"{what}; {_or(fixes)}"


def raise_for_status(code: int, *, step: int, t0: float, h: float, where: str = "", **context) -> None:
    """Return if ``code`` is OK, else raise ``SimulationError`` with ``status_message`` (``context``:
    its keyword arguments), prefixed by ``where`` (e.g. "setups\\[1]: ") to name the failed run."""
    if code == KernelStatus.OK:
        return
    raise SimulationError(where + status_message(code, step=step, t0=t0, h=h, **context))
