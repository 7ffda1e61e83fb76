"""The magnetic experiment's plant: the 'real robot' (the nominal manipulator perturbed by three
factors), its settling and the camera model that measures it. One set of defaults, shared by the
simulated experiment (``softrnn.experiments.magnetic.ExperimentConfig``) and the closed loop
(``softrnn.control.loop.LoopConfig``), which inherit these fields and check them each their own way."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, kw_only=True)
class PlantDefaults:
    """The plant's factors, settling time and camera model (defaults: the magnetic experiment's).

    Attributes
    ----------
    stiffness, remanence, damping : float
        the real robot's Young's modulus, magnet remanence and damping over the nominal values
        (+4 % stiffness, -3 % remanence, 2x the nominal damping; see ``ExperimentConfig``)
    settle : float
        settling time [s] under the first currents before t = 0
    camera_noise : float
        standard deviation [m] of the noise on each coordinate of each sampled centreline point
    camera_points : int
        centreline points the camera reconstructs, evenly spaced in arc length
    polynomial_degree : int
        degree of the polynomial fitted to each coordinate of the centreline
    """

    stiffness: float = 1.04
    remanence: float = 0.97
    damping: float = 2.0
    settle: float = 0.5
    camera_noise: float = 2e-4
    camera_points: int = 100
    polynomial_degree: int = 3
