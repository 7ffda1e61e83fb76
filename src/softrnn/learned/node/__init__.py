"""Per-node LSTM surrogate models (paper section 3, Fig. 2A/B): samples, model, training, folders.

* ``data``: ``SampleSpec``, ``make_windows``, ``split``, ``Normalizer`` (NumPy only);
* ``model``: ``ModelConfig``, ``NodeLSTM`` (PyTorch);
* ``train_config``: ``TrainConfig`` (NumPy only); ``train``: ``train_node_model``;
* ``artifact``: ``NodeModel``, ``save_model``, ``load_model``.

Names are imported lazily, so ``softrnn.learned.node.data`` does not import PyTorch.
"""

from importlib import import_module

_EXPORTS = {
    "SampleSpec": "data", "Windows": "data", "make_windows": "data", "split": "data", "Normalizer": "data",
    "pose_rows": "data", "wrench_rows": "data",
    "ModelConfig": "model", "NodeLSTM": "model",
    "TrainConfig": "train_config", "train_node_model": "train",
    "NodeModel": "artifact", "save_model": "artifact", "load_model": "artifact", "ModelFolderError": "artifact",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
