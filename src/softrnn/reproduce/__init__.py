"""``softrnn reproduce``: the paper's results, step by step, resumable (``pipeline.reproduce``),
and the report they make (``render_markdown``).

* ``pipeline``: ``reproduce``, which runs the steps in order and writes ``report.json`` and ``report.md``;
* ``cases``, ``node_models``, ``manipulator``, ``dynamic``, ``magnetic``, ``fig13``, ``fig14``,
  ``benchmark``: one module per step;
* ``tendons``: the whole-manipulator model of the tendon-driven arms, driven by their tensions alone
  (``tendon_step``; not a step of the pipeline);
* ``stepfiles``: the step files that make a rerun resume;
* ``compare``: a report's accuracy figures against a committed reference (``softrnn reproduce --compare``);
* ``report``: ``render_markdown``, the Markdown report.
"""

from .pipeline import reproduce as reproduce
from .report import render_markdown as render_markdown
