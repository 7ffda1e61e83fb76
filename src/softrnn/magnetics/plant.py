"""The magnetic experiment's plant: the 'real robot' (the nominal manipulator perturbed by three
factors), its settling and the camera that measures it. One set of defaults (``PLANT``), which the
simulated experiment (``softrnn.experiments.magnetic.ExperimentConfig``) and the closed loop
(``softrnn.control.loop.LoopConfig``) take their fields' defaults from, each checking them its own way."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, kw_only=True)
class PlantDefaults:
    """The plant's factors, settling time and camera model (values: the magnetic experiment's).

    Attributes
    ----------
    rate : float
        camera frame rate [Hz] (the control rate of a closed loop)
    stiffness, remanence, damping : float
        the real robot's Young's modulus, magnet remanence and damping over the nominal values
        (+4 % stiffness, -3 % remanence, 2x the nominal damping; reasons in ``ExperimentConfig``)
    settle : float
        settling time [s] under the first currents before t = 0
    camera_noise : float
        standard deviation [m] of the noise on each coordinate of each sampled centreline point
    camera_points : int
        centreline points the camera reconstructs, evenly spaced in arc length
    polynomial_degree : int
        degree of the polynomial fitted to each coordinate of the centreline
    """

    rate: float = 30.0
    stiffness: float = 1.04
    remanence: float = 0.97
    damping: float = 2.0
    settle: float = 0.5
    camera_noise: float = 2e-4
    camera_points: int = 100
    polynomial_degree: int = 3


PLANT = PlantDefaults()
"""The one set of plant defaults."""
