"""The report's entry on the static predictions of the nominal static Cosserat model (paper Sec. 5):
the model itself is ``softrnn.magnetics.static``."""

from __future__ import annotations

from ...magnetics.static import StaticPrediction


def static_summary(static: StaticPrediction, n_steps: int, tol: float) -> dict:
    """The report's ``static`` entry: failures (count, the first 20 samples, the first message),
    solves (total, mean per sample, per second) and the solver's ``n_steps`` and ``tol``."""
    return {"failures": len(static.failures), "failed_samples": [k for k, _ in static.failures][:20],
            "first_failure": static.failures[0][1] if static.failures else None,
            "solves": int(static.solves.sum()), "mean_solves_per_sample": float(static.solves.mean()),
            "n_steps": n_steps, "tol": tol, "solves_per_second": static.solves_per_second}
