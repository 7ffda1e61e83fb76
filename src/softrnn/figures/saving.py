"""The one way softrnn makes and saves pictures: figures made with matplotlib's object API on the Agg
canvas (``new_figure``, ``subplots``; no pyplot, so no global figure list to close), saved atomically
(``save_figure``) or rendered in memory (``figure_bytes``), and the temporary file every output goes
through (``atomic_output``, which the animations write into as well).

An output is written under a temporary name in its own folder (``.NAME.XXXX.tmp.SUFFIX``, hidden)
and renamed onto its path only when complete: an error or Ctrl-C leaves the old file, if any,
untouched and no partial file behind.
"""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

FRAME_DPI = 100
"""Dots per inch of animation frames: a frame of W x H pixels is a W/DPI x H/DPI inch figure (both
looks of ``softrnn animate``, and the ffmpeg writer)."""

from ..files import atomic_output  # noqa: E402  (the one temporary-file helper; animations use it from here)

DPI = 110
"""Resolution [dots per inch] of every saved figure unless a caller asks for another."""


def new_figure(*, figsize: tuple[float, float] | None = None, dpi: float | None = None) -> Figure:
    """A matplotlib ``Figure`` of ``figsize`` [in] (default: matplotlib's) on its own Agg canvas,
    made without pyplot: nothing global holds it, so it needs no closing."""
    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float] | None = None, **kwargs):
    """(figure, axes) like ``pyplot.subplots``: a ``new_figure`` of ``figsize`` with an
    ``nrows`` x ``ncols`` grid of axes (``kwargs`` such as ``sharex`` and ``squeeze`` go to
    ``Figure.subplots``)."""
    fig = new_figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kwargs)


def save_figure(fig: Figure, path, *, dpi: float = DPI) -> Path:
    """Save ``fig`` to ``path`` atomically (``atomic_output``) in the format its suffix names (.png,
    .pdf, .svg, ...) at ``dpi``; returns the path. A suffix matplotlib cannot write raises its
    ``ValueError`` and leaves no file."""
    path = Path(path)
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix[1:].lower() or None)
    return path


def figure_bytes(fig: Figure, fmt: str, *, dpi: float = DPI) -> bytes:
    """``fig`` rendered in memory in the format ``fmt`` (``"png"``, ``"svg"``, ...; a leading dot
    is ignored) at ``dpi``, for a caller that writes it together with other outputs."""
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt.lstrip("."), dpi=dpi)
    return buf.getvalue()
