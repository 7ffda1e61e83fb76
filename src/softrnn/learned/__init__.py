"""Learned models of a soft manipulator, one family with two kinds of model.

* ``node``: the paper's per-node LSTMs (Fig. 2A/B) and their composition into a whole manipulator
  (Fig. 2C): samples, network, training, folders, evaluation, rollouts, the compiled engine, export;
* ``whole``: one model of the whole manipulator (beyond the paper): a subset of the nodes stepped
  at the model's own time step by a global linear term plus a convolution along the rod.

Shared by both kinds (NumPy only):

* ``baselines``: ``Persistence``, ``ConstantVelocity``, ``StateBaseline`` (the simple ones
  stepping the whole model's encoded state), ``one_step``, ``free_run``, ``horizon_errors``,
  ``standard_baselines``;
* ``linear``: ``LinearAR`` (per node or of the whole manipulator, ridge) and ``LinearARX`` (an
  output driven by known inputs, least squares: the lab benchmark's);
* ``horizons``: ``HORIZONS``, ``WHOLE_HORIZONS``, ``HORIZON_STARTS``, ``WHOLE_HORIZON_STARTS``,
  ``free_steps``, ``DIVERGED_M``, ``RolloutDiverged``, ``spread_starts``, ``worst_by_horizon``,
  ``horizon_table``, ``HorizonTable``, ``HorizonRow``;
* ``metrics``: ``tip_errors``, ``TipErrors``, ``euclidean_errors``, ``euclidean_summary``,
  ``aligned_tip_errors`` (after removing a session's constant offset), ``coverage``;
* ``spans``: ``check_span`` and the other checks of an evaluated span;
* ``artifacts``: model folders (``ModelFolderError``, their JSON files and format checks);
* ``checkpoints``: the checkpoint lifecycle of every training (``output_folder``, ``Checkpoint``,
  ``TrainingFolder``);
* ``export``: the ONNX export core (``onnx_graph``, ``onnx_metadata``);
* ``rollout``: a free run as a data set of the reference's format (``predicted_attrs``).

Names are imported lazily.
"""

from importlib import import_module

_EXPORTS = {
    "AbstractBaseline": "baselines", "Persistence": "baselines", "ConstantVelocity": "baselines",
    "StateBaseline": "baselines", "LinearAR": "linear", "LinearARConfig": "linear", "LinearARX": "linear",
    "one_step": "baselines", "free_run": "baselines", "horizon_errors": "baselines",
    "standard_baselines": "baselines", "dataset_wrenches": "baselines",
    "HORIZONS": "horizons", "WHOLE_HORIZONS": "horizons", "free_steps": "horizons", "spread_starts": "horizons",
    "worst_by_horizon": "horizons", "HorizonWorst": "horizons", "HorizonTable": "horizons",
    "DIVERGED_M": "horizons", "RolloutDiverged": "horizons", "HORIZON_STARTS": "horizons",
    "WHOLE_HORIZON_STARTS": "horizons", "horizon_table": "horizons", "HorizonRow": "horizons",
    "tip_errors": "metrics", "TipErrors": "metrics", "euclidean_errors": "metrics", "euclidean_summary": "metrics",
    "aligned_tip_errors": "metrics", "coverage": "metrics",
    "SpanWording": "spans", "check_span": "spans", "check_length": "spans", "check_fit_span": "spans",
    "check_step_start": "spans", "start_of_test_span": "spans", "check_beyond_trained": "spans",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
