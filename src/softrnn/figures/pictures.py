"""Pictures of rod data: a node's trajectory per axis (``plot_node``) and figures saved atomically
(``save_figure``); the animation of the rod over time (``animate``, in ``animation``) and the reading
of rod data for pictures (``load``, ``time_span``, ``frame_indices``, ``node_of_interest``, in
``data``) are re-exported here.

Every function takes a *dataset-like* object: anything with the attributes ``time`` (T,) [s],
``nodes`` (N,) node indices, ``positions`` (T, N, 3) [m] and optionally ``forces`` (T, N, 3) [N]
and ``attrs`` (dict). A ``softrnn.io.dataset.Dataset`` and a ``softrnn.rod.Trajectory`` both fit.

``animate(data, "rod.gif")`` draws the rod at evenly spaced times (by default at most 200 frames
covering the whole record) with the applied forces as arrows (scale chosen automatically and given
in the legend), the node of interest and its trail marked, fixed equal-aspect axes that cover the
whole motion, a flat view when the motion is planar and a 3-D view otherwise. ``.gif`` is written
with Pillow, ``.mp4`` with ffmpeg (when installed). ``plot_node(data, 30, "node30.png")`` draws one
node's x, y, z in mm against time, with the forces on that node in a fourth panel.

Output files are written under a temporary name in the same folder and renamed at the end, so an
error or Ctrl-C never leaves a partial file. Bad input raises ``SoftrnnInputError`` (one line).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ._output import publish  # noqa: E402
from .animation import DEFAULT_SIZE as DEFAULT_SIZE  # noqa: E402
from .animation import animate as animate  # noqa: E402
from .data import ANIMATION_SUFFIXES as ANIMATION_SUFFIXES  # noqa: E402
from .data import DEFAULT_MAX_FRAMES as DEFAULT_MAX_FRAMES  # noqa: E402
from .data import FIGURE_SUFFIXES as FIGURE_SUFFIXES  # noqa: E402
from .data import _column, _fields, _resolve  # noqa: E402
from .data import _title as _title  # noqa: E402
from .data import check_suffix as check_suffix  # noqa: E402
from .data import describe_nodes as describe_nodes  # noqa: E402
from .data import frame_indices as frame_indices  # noqa: E402
from .data import load as load  # noqa: E402
from .data import node_of_interest as node_of_interest  # noqa: E402
from .data import time_span as time_span  # noqa: E402
from .geometry import VIEWS as VIEWS  # noqa: E402
from .geometry import choose_view as choose_view  # noqa: E402
from .geometry import force_scale as force_scale  # noqa: E402


def plot_node(data, node: int, out_path=None, *, start: float | None = None, stop: float | None = None,
              forces: bool = True, title: str | None = None):
    """Figure of one node's x, y, z [mm] against time [s], with the forces on it [N] in a fourth panel
    (when ``forces`` and the data has non-zero forces on that node). Saved atomically to ``out_path``
    (.png, .pdf, .svg) when given; returns the path, else returns the Figure."""
    from .plots import node_trajectory_with_forces

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


def save_figure(fig, path, dpi: int = 110) -> None:
    """Save ``fig`` to ``path`` atomically (temporary name in the same folder, then rename; nothing is
    left behind on error) and close it."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}", dir=path.parent)
        os.close(fd)
        try:
            fig.savefig(tmp, dpi=dpi)
            publish(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise
    finally:
        plt.close(fig)
