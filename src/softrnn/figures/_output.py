"""Atomic output files for pictures: written under a temporary name in the target folder, then
renamed, so an error or Ctrl-C never leaves a partial file."""

from __future__ import annotations

import os
from pathlib import Path


def publish(tmp: str, path: Path) -> None:
    """Give the finished temporary file the usual permissions (mkstemp makes it 0600) and rename it."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o666 & ~mask)
    os.replace(tmp, path)
