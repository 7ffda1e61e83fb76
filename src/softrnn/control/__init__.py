"""Closed-loop control of the magnetic rod: the plant stepped frame by frame and measured by the camera
(``loop``), reference trajectories (``references``) and controllers (``controllers``: ``static_inverse``,
and ``mpc.BlockMPC`` planning with a ``predictors.Predictor``: ``model.NarxPredictor`` or
``physics_mpc.PhysicsPredictor``)."""
