"""MkDocs hook: strict-mode warnings that come from docstrings in src/ and are known, listed one by one.

The site is built with ``--strict``, so every warning fails the build. The warnings below come
from docstrings in ``src/`` (to be fixed there, not here) and are dropped by exact message (the
file and the text, without the line number, so that edits elsewhere in a file do not matter).
Any other warning, including a new one in the same file, still fails the build.

TODO(docstrings): remove each entry once its docstring is fixed; the list should end up empty.
An entry that no longer matches anything is reported at the end of the build (INFO).

* griffe (numpy docstring style): text after the last entry of a ``Parameters`` section, without a
  new section heading (``Notes`` + dashes), is read as more parameters;
* mkdocs_autorefs: ``[a] [b]`` in Markdown is a reference-style link, e.g. ``[...] [J]`` or
  ``[B; g]``; write ``\\[J]`` or use other brackets.
"""

import logging
import re

# (logger prefix, source file, message without the line number)
_NUMPY_SECTIONS = {
    # Dataset: the paragraph after the Parameters entries
    "src/softrnn/io/dataset.py": ("Arrays", "never", "Use", "Invalid", "quaternions", "positions", "the", "Every"),
    # export_csv
    "src/softrnn/io/csv_import.py": ("Columns", "quaternion", "nodes", "Values"),
    # ManipulatorStepper
    "src/softrnn/surrogate/engine.py": ("last", "they", "returns", "modelled"),
    # PhysicalNodeModel
    "src/softrnn/surrogate/export.py": ("The", "every"),
}
KNOWN: set[tuple[str, str, str]] = set()
for _file, _names in _NUMPY_SECTIONS.items():
    for _name in _names:
        KNOWN.add(("griffe", _file, f"Parameter '{_name}' does not appear in the function signature"))
        KNOWN.add(("griffe", _file, f"No types or annotations for parameters ['{_name}']"))
KNOWN -= {("griffe", "src/softrnn/io/dataset.py", f"No types or annotations for parameters ['{name}']")
          for name in ("quaternions", "positions")}   # reported together, below
KNOWN |= {
    ("griffe", "src/softrnn/io/dataset.py", "No types or annotations for parameters ['quaternions', 'positions']"),
    ("griffe", "src/softrnn/surrogate/engine.py", ("Could not parse line '``reset(positions (H, N, 3), wrenches "
                                                   "(H, B, W), quaternions (H, N, 4) or None)`` loads the'")),
    ("griffe", "src/softrnn/surrogate/export.py", ("Could not parse line '``normalise_wrenches``, the module, "
                                                   "``denormalise_outputs``) for ``relative`` on or off and'")),
    # mkdocs_autorefs: (origin object) and the bracketed text read as a link target
    ("mkdocs_autorefs", "src/softrnn/magnetics/magnets.py",
     "(softrnn.magnetics.magnets.wrench_matrix) Could not find cross-reference target 'B; g'"),
    ("mkdocs_autorefs", "src/softrnn/rod/discrete.py",
     "(softrnn.rod.discrete.strain_energy) Could not find cross-reference target 'J'"),
    ("mkdocs_autorefs", "src/softrnn/rod/kernels.py",
     "(softrnn.rod.kernels.advance_into) Could not find cross-reference target 'N'"),
    ("mkdocs_autorefs", "src/softrnn/statics/rod.py",
     "(softrnn.statics.rod.RigidSegment) Could not find cross-reference target 'm'"),
}

# griffe: "griffe: src/x.py:118: message"; autorefs: "mkdocs_autorefs: page.md: from /abs/src/x.py:27: message"
_GRIFFE = re.compile(r"^griffe: (?P<file>\S+?):\d+: (?P<text>.*)$", re.DOTALL)
_AUTOREFS = re.compile(r"^mkdocs_autorefs: \S+: from (?P<file>\S+?):\d+: (?P<text>.*)$", re.DOTALL)
_seen: set[tuple[str, str, str]] = set()
_log = logging.getLogger("mkdocs.hooks.known_warnings")


def _key(message: str):
    for prefix, pattern in (("griffe", _GRIFFE), ("mkdocs_autorefs", _AUTOREFS)):
        m = pattern.match(message)
        if m:
            file = m["file"].replace("\\", "/")
            file = file[file.rfind("src/"):] if "src/" in file else file
            return prefix, file, m["text"]
    return None


class _DropKnown(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno != logging.WARNING:
            return True
        key = _key(record.getMessage())
        if key in KNOWN:
            _seen.add(key)
            return False
        return True


_FILTER = _DropKnown()


def on_config(config):
    # on the handlers of the "mkdocs" logger (the console and, with --strict, the warning counter
    # that mkdocs adds before on_config), so that any plugin's logger name is covered
    for handler in logging.getLogger("mkdocs").handlers:
        if _FILTER not in handler.filters:
            handler.addFilter(_FILTER)
    return config


def on_post_build(config):
    if _seen:
        _log.info("known_warnings: %d known docstring warnings from src/ dropped (docs/_hooks/known_warnings.py)",
                  len(_seen))
    stale = sorted(KNOWN - _seen)
    if stale:
        _log.info("known_warnings: %d entries matched nothing and can be removed: %s", len(stale), stale)
    _seen.clear()
