"""Magnetic actuation: electromagnets as point dipoles, embedded permanent magnets, and the magnetic
manipulator in the dynamic simulator (magnetic.md; Tariverdi et al. 2021, Fig. 9)."""

from .coils import (MU0 as MU0, Coil as Coil, CoilLayout as CoilLayout, actuation_matrix as actuation_matrix,
                    bigmag_like as bigmag_like, dipole_field as dipole_field, dipole_gradient as dipole_gradient,
                    field as field, gradient as gradient, pack5 as pack5, unit_field_maps as unit_field_maps,
                    unpack5 as unpack5)
from .magnets import (GRADES as GRADES, Magnet as Magnet, default_magnets as default_magnets, force as force,
                      force_matrix as force_matrix, moment_world as moment_world, torque as torque,
                      wrench as wrench, wrench_matrix as wrench_matrix)
from .manipulator import (CurrentSchedule as CurrentSchedule, ManipulatorRun as ManipulatorRun,
                          ManipulatorSpec as ManipulatorSpec, ManipulatorTrajectory as ManipulatorTrajectory,
                          currents_for_field as currents_for_field, random_currents as random_currents,
                          simulate_manipulator as simulate_manipulator)
