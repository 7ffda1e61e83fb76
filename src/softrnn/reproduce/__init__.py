"""``softrnn reproduce``: the paper's results, step by step, resumable (``pipeline.reproduce``),
and the report they make (``render_markdown``)."""

from .pipeline import render_markdown as render_markdown
from .pipeline import reproduce as reproduce
