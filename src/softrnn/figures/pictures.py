"""A picture of one node of rod data (``plot_node``): its x, y, z against time, with the forces on it.

``plot_node`` takes a *dataset-like* object: anything with the attributes ``time`` (T,) [s],
``nodes`` (N,) node indices, ``positions`` (T, N, 3) [m] and optionally ``forces`` (T, N, 3) [N]
and ``attrs`` (dict). A ``softrnn.io.Dataset`` and a ``softrnn.rod.Trajectory`` both fit.
``plot_node(data, 30, "node30.png")`` draws one node's x, y, z in mm against time, with the forces
on that node in a fourth panel and the data's actuation inputs (tendon tensions, displacements,
currents) below; with ``reference=`` a prediction is drawn over its reference data.

The file is written under a temporary name in the same folder and renamed at the end
(``saving.save_figure``), so an error or Ctrl-C never leaves a partial file. Bad input raises
``SoftrnnInputError`` (one line).
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from .data import FIGURE_SUFFIXES, _column, _fields, _resolve, _title, check_suffix, time_span
from .overlay import predicted_from, reference_positions
from .plots import node_panels
from .saving import save_figure


def plot_node(data, node: int, out_path=None, *, start: float | None = None, stop: float | None = None,
              forces: bool = True, title: str | None = None, inputs: bool = True, reference=None):
    """Figure of one node's x, y, z [mm] against time [s], with the forces on it [N] in a panel
    (when ``forces`` and the data has non-zero forces on that node) and the data's actuation inputs
    in a panel per unit (when ``inputs`` and the data has any: ``actuation`` (T, m),
    ``actuation_units``). ``reference``: dataset-like data that ``data`` predicts (``figures.overlay``),
    drawn dashed under it with the node's error. Saved atomically to ``out_path`` (.png, .pdf, .svg)
    when given; returns the path, else returns the Figure."""
    if out_path is not None:
        check_suffix(out_path, FIGURE_SUFFIXES)
    time, nodes, positions, F, attrs = _fields(data)
    col = _column(nodes, _resolve(node, nodes, attrs))
    i0, i1 = time_span(time, start, stop)
    sl = slice(i0, i1 + 1)
    f = F[sl, col] if forces and F is not None else None
    if f is not None and not np.any(f):
        f = None
    act, units = _inputs(data) if inputs else (None, None)
    ref = None
    if reference is not None:
        ref = reference_positions(SimpleNamespace(time=time[sl], nodes=nodes[col:col + 1]), reference)[:, 0]
    fig = node_panels(time[sl], np.asarray(positions[sl, col], dtype=float), forces=f,
                      inputs=None if act is None else act[sl], units=units, reference=ref,
                      start=predicted_from(attrs) if ref is not None else None,
                      title=title or f"{_title(attrs)}: node {int(nodes[col])}"
                      + (" over its reference" if ref is not None else ""))
    if out_path is None:
        return fig
    save_figure(fig, out_path)
    return Path(out_path)


def _inputs(data) -> tuple[np.ndarray | None, dict | None]:
    """The data's actuation inputs (T, m) and {channel: unit}, or (None, None) without any."""
    units = dict(getattr(data, "actuation_units", None) or {})
    act = getattr(data, "actuation", None)
    if not units or act is None or np.size(act) == 0:
        return None, None
    return np.asarray(act, dtype=float), units
