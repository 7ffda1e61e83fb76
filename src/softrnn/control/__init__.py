"""Closed-loop control of the magnetic rod (issue 14): the plant stepped frame by frame and measured
by the camera (``loop``), reference trajectories (``references``) and controllers (``controllers``: ``static_inverse``,
``mpc``, ``physics_mpc``)."""
