"""Coil currents of the magnetic manipulator as time inputs: a ``CurrentSchedule`` (linear between
samples, held outside), smooth random currents (``random_currents``) and the currents that make a
wanted field at a point (``currents_for_field``); magnetic.md §2.5-2.6."""

import math
from dataclasses import dataclass

import numpy as np

from ..errors import bad, store_frozen
from ..rod.loads import smoothstep
from .coils import CoilLayout, unit_field_maps


@dataclass(frozen=True, eq=False)
class CurrentSchedule:
    """Coil currents as time inputs: values (T, n) [A] at increasing times (T,) [s], linear in
    between, held at the first/last value outside."""

    times: np.ndarray
    values: np.ndarray

    def __post_init__(self):
        # private C-ordered copies, frozen (the caller's arrays stay writable)
        t = np.array(self.times, dtype=float, order="C")
        v = np.array(self.values, dtype=float, order="C")
        if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise bad("currents.times", f"array of shape {t.shape}",
                      "a 1-D array of strictly increasing finite times in s")
        if v.ndim != 2 or v.shape[0] != t.size or not np.all(np.isfinite(v)):
            raise bad("currents.values.shape", v.shape, f"({t.size}, n_coils) finite currents in A, one row per time")
        store_frozen(self, times=t, values=v)

    @property
    def n_coils(self) -> int:
        """Coils n (columns of values)."""
        return self.values.shape[1]

    def __call__(self, t) -> np.ndarray:
        """Currents (K, n) [A] at times t (K,) [s]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.stack([np.interp(t, self.times, self.values[:, k]) for k in range(self.n_coils)], -1)


def random_currents(layout: CoilLayout, duration: float, *, seed: int, band: tuple = (0.1, 2.0),
                    n_components: int = 6, peak: float = 0.9, ramp: float = 1.0,
                    rate: float = 1000.0) -> CurrentSchedule:
    """Smooth, band-limited random currents for every coil, reproducible from ``seed``.

    Each coil's current is a sum of ``n_components`` sinusoids with frequencies drawn log-uniformly
    in ``band`` [Hz], random phases and amplitudes, scaled so that its largest |I| is
    ``peak * layout.current_limit``, and faded in from zero over ``ramp`` [s] (smoothstep). The
    schedule is sampled at ``rate`` [Hz] from 0 to ``duration`` [s]; linear interpolation between
    samples never exceeds the sampled peak, so the bound holds at every time.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise bad("seed", seed, "an integer")
    for name, value in (("duration", duration), ("rate", rate)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
            raise bad(name, value, "a positive finite number")
    if not (isinstance(peak, (int, float)) and 0 < peak <= 1):
        raise bad("peak", peak, "a fraction in (0, 1] of the current limit")
    if not (isinstance(ramp, (int, float)) and np.isfinite(ramp) and ramp >= 0):
        raise bad("ramp", ramp, "a fade-in time >= 0 in s")
    try:
        f_lo, f_hi = (float(b) for b in band)
    except (TypeError, ValueError):
        raise bad("band", band, "(f_min, f_max) in Hz") from None
    if not (0 < f_lo <= f_hi < 0.5 * rate):
        raise bad("band", band, f"0 < f_min <= f_max < rate/2 = {0.5 * rate:g} Hz")
    if isinstance(n_components, bool) or not isinstance(n_components, int) or n_components < 1:
        raise bad("n_components", n_components, "an integer >= 1")
    rng = np.random.default_rng(seed)
    n = layout.n_coils
    t = np.arange(int(math.ceil(duration * rate)) + 1) / rate
    freq = np.exp(rng.uniform(math.log(f_lo), math.log(f_hi), size=(n, n_components)))
    phase = rng.uniform(0.0, 2.0 * math.pi, size=(n, n_components))
    amp = rng.uniform(0.5, 1.0, size=(n, n_components))
    I = np.einsum("kc,tkc->tk", amp, np.sin(2.0 * math.pi * freq[None] * t[:, None, None] + phase[None]))
    fade = smoothstep(t / ramp) if ramp > 0 else np.ones_like(t)
    I *= fade[:, None]
    scale = np.max(np.abs(I), axis=0)
    I *= peak * layout.current_limit / np.where(scale > 0, scale, 1.0)
    return CurrentSchedule(t, I)


def currents_for_field(layout: CoilLayout, point, field_t) -> np.ndarray:
    """Minimum-norm currents (n,) [A] that produce the field ``field_t`` (3,) [T] at ``point`` (3,) [m]
    (I = pinv(A_B(p)) B, magnetic.md §2.6; gradients are left uncontrolled). Raises if beyond the limit."""
    beta, _ = unit_field_maps(layout, point)
    b = np.asarray(field_t, dtype=float)
    if b.shape != (3,) or not np.all(np.isfinite(b)):
        raise bad("field", field_t, "a finite 3-vector in T")
    I = np.linalg.pinv(beta) @ b
    return layout.check_currents(I, "currents for the requested field")
