"""A picture of one node of rod data (``plot_node``): its x, y, z against time, with the forces on it.

``plot_node`` takes a *dataset-like* object: anything with the attributes ``time`` (T,) [s],
``nodes`` (N,) node indices, ``positions`` (T, N, 3) [m] and optionally ``forces`` (T, N, 3) [N]
and ``attrs`` (dict). A ``softrnn.io.Dataset`` and a ``softrnn.rod.Trajectory`` both fit.
``plot_node(data, 30, "node30.png")`` draws one node's x, y, z in mm against time, with the forces
on that node in a fourth panel.

The file is written under a temporary name in the same folder and renamed at the end
(``saving.save_figure``), so an error or Ctrl-C never leaves a partial file. Bad input raises
``SoftrnnInputError`` (one line).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .data import FIGURE_SUFFIXES, _column, _fields, _resolve, _title, check_suffix, time_span
from .plots import node_trajectory_with_forces
from .saving import save_figure


def plot_node(data, node: int, out_path=None, *, start: float | None = None, stop: float | None = None,
              forces: bool = True, title: str | None = None):
    """Figure of one node's x, y, z [mm] against time [s], with the forces on it [N] in a fourth panel
    (when ``forces`` and the data has non-zero forces on that node). Saved atomically to ``out_path``
    (.png, .pdf, .svg) when given; returns the path, else returns the Figure."""
    if out_path is not None:
        check_suffix(out_path, FIGURE_SUFFIXES)
    time, nodes, positions, F, attrs = _fields(data)
    col = _column(nodes, _resolve(node, nodes, attrs))
    i0, i1 = time_span(time, start, stop)
    sl = slice(i0, i1 + 1)
    f = F[sl, col] if forces and F is not None else None
    if f is not None and not np.any(f):
        f = None
    fig = node_trajectory_with_forces(time[sl], positions[sl, col], f,
                                      title or f"{_title(attrs)}: node {int(nodes[col])}")
    if out_path is None:
        return fig
    save_figure(fig, out_path)
    return Path(out_path)
