"""Magnetic actuation: electromagnets as point dipoles, embedded permanent magnets, and the magnetic
manipulator in the dynamic simulator (magnetic.md; Tariverdi et al. 2021, Fig. 9)."""

from .coils import MU0 as MU0
from .coils import Coil as Coil
from .coils import CoilLayout as CoilLayout
from .coils import actuation_matrix as actuation_matrix
from .coils import bigmag_like as bigmag_like
from .coils import dipole_field as dipole_field
from .coils import dipole_gradient as dipole_gradient
from .coils import field as field
from .coils import gradient as gradient
from .coils import pack5 as pack5
from .coils import unit_field_maps as unit_field_maps
from .coils import unpack5 as unpack5
from .currents import CurrentSchedule as CurrentSchedule
from .currents import currents_for_field as currents_for_field
from .currents import random_currents as random_currents
from .magnets import GRADES as GRADES
from .magnets import Magnet as Magnet
from .magnets import default_magnets as default_magnets
from .magnets import force as force
from .magnets import force_matrix as force_matrix
from .magnets import moment_world as moment_world
from .magnets import torque as torque
from .magnets import wrench as wrench
from .magnets import wrench_matrix as wrench_matrix
from .manipulator import BaseAdvance as BaseAdvance
from .manipulator import ManipulatorRun as ManipulatorRun
from .manipulator import ManipulatorSpec as ManipulatorSpec
from .manipulator import ManipulatorTrajectory as ManipulatorTrajectory
from .manipulator import simulate_manipulator as simulate_manipulator
