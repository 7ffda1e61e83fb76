"""A Fig. 14 study's summary (``summary`` -> ``StudySummary``: its tables, regions (``Region``) and
trends beside the paper's ``PAPER_FIG14``; ``StudyResult``: a finished study) and figure (``fig14_figure``: the
heatmaps over LSTM units x history size)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import final

import numpy as np
from matplotlib.colors import LogNorm
from matplotlib.patches import Rectangle

from ..figures.saving import subplots
from .fig14_config import PAPER_FIG14, StudyConfig


def _table(config: StudyConfig, records: list[dict], value) -> np.ndarray:
    """(len(history), len(units)) array of ``value(record)`` (NaN where None)."""
    t = np.full((len(config.history), len(config.units)), np.nan)
    for r in records:
        v = value(r)
        if v is not None:
            t[config.history.index(r["history"]), config.units.index(r["units"])] = v
    return t


def _stepper_hz(r):
    return r["bandwidth"]["stepper"]["hz"] if r.get("bandwidth") else None


def _torch_hz(r):
    b = r.get("bandwidth")
    return b["torch"]["hz"] if b and b.get("torch") else None


def _rmse(r):
    return r["error"]["rmse_mm"]


@final
@dataclass(frozen=True)
class Region:
    """The grid points near the best of a study's table (``region``); ``to_dict()`` is its JSON form."""

    best: dict
    """{units, history, value}: the best grid point and its value (Hz or mm)."""
    criterion: str
    """The tolerance, e.g. ``">= 0.9 x the best"``."""
    points: list
    """The grid points [units, history] within the tolerance, sorted."""
    units: list
    """The range [lo, hi] of LSTM units the points span."""
    history: list
    """The range [lo, hi] of history sizes the points span."""
    paper: dict | None = None
    """The paper's region {history, lstm_units} beside it (``summary``; None: not set beside it)."""
    fraction_in_paper_region: float | None = None
    """The fraction of ``points`` inside the paper's region (None: not set beside it)."""

    def to_dict(self) -> dict:
        """Every field in order (``paper`` and ``fraction_in_paper_region`` only where set)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        if self.paper is None:
            del out["paper"], out["fraction_in_paper_region"]
        return out


def region(config: StudyConfig, table: np.ndarray, *, maximise: bool) -> Region | None:
    """The grid points within ``config.region_tolerance`` of the best value of ``table``
    (len(history), len(units)): ``best`` {units, history, value}, ``points`` [[units, history]],
    and the ranges they span, ``units`` [lo, hi] and ``history`` [lo, hi]. None if all NaN."""
    if not np.isfinite(table).any():
        return None
    tol = config.region_tolerance
    best = np.nanmax(table) if maximise else np.nanmin(table)
    i, j = np.argwhere(table == best)[0]
    with np.errstate(invalid="ignore"):
        inside = table >= (1 - tol) * best if maximise else table <= (1 + tol) * best
    pts = [[config.units[b], config.history[a]] for a, b in np.argwhere(inside)]
    us, hs = [p[0] for p in pts], [p[1] for p in pts]
    return Region(best={"units": config.units[j], "history": config.history[i], "value": float(best)},
                  criterion=f"{'>=' if maximise else '<='} {(1 - tol) if maximise else (1 + tol):g} x the best",
                  points=sorted(pts), units=[min(us), max(us)], history=[min(hs), max(hs)])


def _in_paper_region(points: list, paper: dict) -> float:
    """Fraction of ``points`` [[units, history]] inside the paper's ranges (closed)."""
    lo_u, hi_u = paper["lstm_units"]
    lo_h, hi_h = paper["history"]
    inside = [lo_u <= u <= hi_u and lo_h <= h <= hi_h for u, h in points]
    return sum(inside) / len(inside) if inside else math.nan


def trend(table: np.ndarray, axis: int) -> float | None:
    """Mean relative change of ``table`` from the smallest to the largest grid value along
    ``axis`` (0: history, 1: units), e.g. -0.5: halved; None with a single grid value."""
    if table.shape[axis] < 2:
        return None
    first, last = (table[0], table[-1]) if axis == 0 else (table[:, 0], table[:, -1])
    ok = np.isfinite(first) & np.isfinite(last) & (first != 0)
    return float(np.mean(last[ok] / first[ok] - 1.0)) if ok.any() else None


@dataclass(frozen=True)
class StudySummary:
    """The tables, regions and trends of a Fig. 14 study beside the paper's (``summary``);
    ``to_dict()`` is its JSON form. Tables are lists of rows (len(history), len(units)), None where
    a point has no value.

    Attributes
    ----------
    config : StudyConfig
        The study's settings.
    units : list of int
        The grid's LSTM units (the tables' columns).
    history : list of int
        The grid's history sizes (the tables' rows).
    points : list of dict
        Each grid point's record (the point file's content), in grid order.
    bandwidth_hz : list of list
        The compiled stepper's bandwidth [Hz] (len(history), len(units)).
    torch_bandwidth_hz : list of list
        Eager PyTorch's bandwidth [Hz] (len(history), len(units)); None where not measured.
    rmse_mm : list of list
        The one-step RMS error on the test span [mm] (len(history), len(units)).
    regions : dict
        {bandwidth, torch_bandwidth, rms_error: a ``Region`` with ``paper`` and
        ``fraction_in_paper_region``, or None}.
    trends : dict
        {bandwidth, torch_bandwidth, rms_error}_vs_{units, history}: ``trend`` (relative change) or None.
    paper : dict
        The paper's statements (``PAPER_FIG14``: source, bandwidth, rms_error and their regions).
    """

    config: StudyConfig
    units: list
    history: list
    points: list
    bandwidth_hz: list
    torch_bandwidth_hz: list
    rmse_mm: list
    regions: dict
    trends: dict
    paper: dict

    def to_dict(self) -> dict:
        """The JSON summary: ``config`` (``StudyConfig.to_dict``), then every other field in order
        (``regions`` as ``Region.to_dict``)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["config"] = self.config.to_dict()
        out["regions"] = {k: None if r is None else r.to_dict() for k, r in self.regions.items()}
        return out


@final
@dataclass(frozen=True)
class StudyResult(StudySummary):
    """A finished Fig. 14 study (``experiments.fig14.run_study``): its ``StudySummary`` and the run's
    record; ``to_dict()`` is the study's JSON summary (``softrnn study hparams --json``).

    Attributes
    ----------
    data : dict
        The data file's record in the manifest (path, SHA-256).
    out_dir : str
        The study folder.
    computed, measured, found : list of [units, history]
        The points trained by this run, timed by this run, and found finished (with bandwidths).
    figure : str
        The heatmaps' file (``fig14.png`` in the study folder).
    wall_seconds : float
        The run's wall time [s].
    """

    data: dict
    out_dir: str
    computed: list
    measured: list
    found: list
    figure: str
    wall_seconds: float


def summary(config: StudyConfig, records: list[dict]) -> StudySummary:
    """The tables, regions and trends of a study's point records, beside the paper's Fig. 14."""
    bw, tbw, err = (_table(config, records, f) for f in (_stepper_hz, _torch_hz, _rmse))

    def listed(t):
        return [[None if not np.isfinite(v) else float(v) for v in row] for row in t]

    regions = {}
    for name, table, maximise, paper_key in (("bandwidth", bw, True, "bandwidth_region"),
                                             ("torch_bandwidth", tbw, True, "bandwidth_region"),
                                             ("rms_error", err, False, "rms_error_region")):
        reg = region(config, table, maximise=maximise)
        if reg is not None:
            paper = PAPER_FIG14[paper_key]
            reg = replace(reg, paper=paper, fraction_in_paper_region=_in_paper_region(reg.points, paper))
        regions[name] = reg
    trends = {"bandwidth_vs_units": trend(bw, 1), "bandwidth_vs_history": trend(bw, 0),
              "torch_bandwidth_vs_units": trend(tbw, 1), "torch_bandwidth_vs_history": trend(tbw, 0),
              "rms_error_vs_units": trend(err, 1), "rms_error_vs_history": trend(err, 0)}
    return StudySummary(config=config, units=list(config.units), history=list(config.history), points=records,
                        bandwidth_hz=listed(bw), torch_bandwidth_hz=listed(tbw), rmse_mm=listed(err),
                        regions=regions, trends=trends,
                        paper={k: PAPER_FIG14[k] for k in ("source", "bandwidth", "rms_error", "bandwidth_region",
                                                           "rms_error_region")})


# ------------------------------------------------------------------------------------------ figure
def _short(v: float) -> str:
    """3 significant digits, thousands as k: 0.357, 1.98k, 446k."""
    return f"{v / 1e3:.3g}k" if abs(v) >= 1e3 else f"{v:.3g}"


def fig14_figure(result: StudySummary):
    """The Fig. 14 heatmaps of a study ``summary`` (a ``StudySummary``): (A) bandwidth of the compiled stepper [Hz],
    (A') of eager PyTorch [Hz] when measured, (B) one-step RMS error [mm], over LSTM units (x) and
    history size (y). Solid outlines: the region found (within the tolerance of the best); dashed:
    the grid points inside the paper's region; the error's colour scale is logarithmic. Returns
    the matplotlib Figure."""

    units, hist = result.units, result.history
    panels = [("A: bandwidth, compiled stepper [Hz]", result.bandwidth_hz, "bandwidth", "viridis")]
    if any(v is not None for row in result.torch_bandwidth_hz for v in row):
        panels.append(("A': bandwidth, eager PyTorch [Hz]", result.torch_bandwidth_hz, "torch_bandwidth",
                       "viridis"))
    panels.append(("B: one-step RMS error [mm]", result.rmse_mm, "rms_error", "magma_r"))
    fig, axes = subplots(1, len(panels), figsize=(4.6 * len(panels), 3.2 + 0.35 * len(hist)), squeeze=False)
    for ax, (title, rows, key, cmap) in zip(axes[0], panels):
        t = np.array([[np.nan if v is None else v for v in row] for row in rows], dtype=float)
        finite = t[np.isfinite(t)]
        log = key == "rms_error" and finite.size > 0 and finite.min() > 0      # errors span decades
        norm = LogNorm(finite.min(), finite.max()) if log else None
        im = ax.imshow(t, origin="lower", cmap=cmap, aspect="auto", norm=norm)
        fig.colorbar(im, ax=ax, shrink=0.85)
        mid = (np.sqrt(finite.min() * finite.max()) if log else 0.5 * (finite.min() + finite.max())) \
            if finite.size else 0.0
        for a in range(t.shape[0]):
            for b in range(t.shape[1]):
                if np.isfinite(t[a, b]):
                    light = (t[a, b] < mid) == (cmap == "viridis")
                    ax.text(b, a, _short(t[a, b]), ha="center", va="center", fontsize=7,
                            color="white" if light else "black")
        reg = result.regions.get(key)
        if reg is not None:
            for u, h in reg.points:
                ax.add_patch(Rectangle((units.index(u) - 0.5, hist.index(h) - 0.5), 1, 1, fill=False,
                                       edgecolor="red", lw=2.0))
            paper = reg.paper
            for a, h in enumerate(hist):
                for b, u in enumerate(units):
                    if paper["lstm_units"][0] <= u <= paper["lstm_units"][1] and \
                            paper["history"][0] <= h <= paper["history"][1]:
                        ax.add_patch(Rectangle((b - 0.42, a - 0.42), 0.84, 0.84, fill=False, edgecolor="cyan",
                                               lw=1.0, ls="--"))
        ax.set_xticks(range(len(units)), [str(u) for u in units])
        ax.set_yticks(range(len(hist)), [str(h) for h in hist])
        ax.set_xlabel("LSTM units")
        ax.set_ylabel("history size H")
        ax.set_title(title, fontsize=9)
    fig.suptitle("Fig. 14 study (red: within the tolerance of the best; dashed cyan: the paper's region)",
                 fontsize=9)
    fig.tight_layout()
    return fig
