"""The learned dynamic model of the whole manipulator (beyond the paper): one set of weights along
the rod, free running step after step at its own (coarser) time step on a subset of the nodes.

* ``encoding``: ``Encoding``: the state a model sees (reduced nodes, displacements and rotation
  vectors from a reference pose, window-mean loads) and the way back to every node (NumPy only);
* ``config``: ``DynamicConfig`` (frozen, validated);
* ``network``: ``DynamicNet`` (PyTorch): a global linear term plus a 1-D convolution along the rod;
* ``training``: ``train_dynamic_model`` (unrolled multi-step loss, noise injection, resumable);
* ``engine``: ``DynamicEngine``: the trained model in NumPy (and one numba kernel), stepping free
  (one core, no PyTorch);
* ``artifact``: ``save_dynamic``, ``load_dynamic``;
* ``evaluation``: errors at every node beside persistence, constant velocity and a linear model;
* ``data``: ``split_inputs`` (training parts and held-out variants of files and sweep folders);
* ``fit``: ``fit`` (train on a ``Split``);
* ``rollout``: ``rollout_dataset`` (a free run as a data set of every node).

Names are imported lazily, so the NumPy parts do not import PyTorch.
"""

from importlib import import_module

_EXPORTS = {
    "Encoding": "encoding", "Trajectory": "encoding",
    "DynamicConfig": "config",
    "DynamicNet": "network",
    "train_dynamic_model": "training", "TrainedDynamic": "training",
    "DynamicEngine": "engine",
    "save_dynamic": "artifact", "load_dynamic": "artifact",
    "evaluate_dynamic": "evaluation",
    "split_inputs": "data", "Split": "data",
    "fit": "fit",
    "rollout_dataset": "rollout",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
