"""Learned models of a soft manipulator, one family with two kinds of model.

* ``node``: the paper's per-node LSTMs (Fig. 2A/B) and their composition into a whole manipulator
  (Fig. 2C): samples, network, training, folders, evaluation, rollouts, the compiled engine, export;
* ``whole``: one model of the whole manipulator (beyond the paper): a subset of the nodes stepped
  at the model's own time step by a global linear term plus a convolution along the rod.
"""
