"""Libraries the command modules name at their top but load only when a command first uses them, so
that ``softrnn --help``, ``--version`` and bare ``softrnn`` start without them
(tests/cli/test_startup.py)."""

import importlib


class LazyModule:
    """A module loaded on its first attribute access: ``np = LazyModule("numpy")``, then ``np.zeros``
    imports numpy. Modules that use one in annotations start with ``from __future__ import
    annotations``, so that defining a function does not load it."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr: str):
        return getattr(importlib.import_module(self._name), attr)


numpy = LazyModule("numpy")
"""numpy, loaded when a command first uses it."""
