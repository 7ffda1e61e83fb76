"""PyTorch's intra-op thread count, set for a block of work and restored after."""

from __future__ import annotations

import sys
from contextlib import contextmanager


@contextmanager
def torch_threads(threads: int | None):
    """Torch's intra-op thread count set to ``threads`` inside (None, or torch not imported:
    unchanged), the caller's count restored after. Tiny forwards (one window per node, a batch of
    one) run fastest on one thread; training sets the count so that its results do not depend on
    the machine's."""
    torch = sys.modules.get("torch")
    if threads is None or torch is None:
        yield
        return
    old = torch.get_num_threads()
    torch.set_num_threads(int(threads))
    try:
        yield
    finally:
        torch.set_num_threads(old)
