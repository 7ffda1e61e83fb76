"""The magnetic manipulator as a rod run: its magnets are a ``MagneticDipoles`` load of a plain
``Setup`` (``softrnn.rod.magnetic``), stepped by either integrator; a batch refuses the load."""

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.magnetics.manipulator import (
    CurrentSchedule,
    ManipulatorRun,
    ManipulatorSpec,
    magnetic_load,
    manipulator_simulator,
    random_currents,
    simulate_manipulator,
)
from softrnn.rod import RunConfig, simulate_batch
from softrnn.rod.integrators import Implicit
from softrnn.rod.magnetic import MagneticDipoles


def _spec_and_currents():
    spec = ManipulatorSpec(n_nodes=11)
    return spec, random_currents(spec.coils, 0.1, seed=5, ramp=0.02, band=(2.0, 20.0))


def test_the_manipulator_is_a_simulator_run_with_a_magnetic_load():
    spec, currents = _spec_and_currents()
    run = ManipulatorRun(dt=0.01, n_samples=6)
    traj = simulate_manipulator(spec, currents, run)
    sim = manipulator_simulator(spec, currents, traj.step)
    assert isinstance(sim.setup.loads[0], MagneticDipoles) and len(sim.setup.loads) == 1
    rod = sim.run(RunConfig(dt=run.dt, n_samples=run.n_samples, substeps=traj.substeps))
    assert np.array_equal(rod.positions, traj.positions)
    assert np.array_equal(rod.magnets.wrenches, traj.wrenches)
    assert np.allclose(rod.magnets.currents, currents(rod.time), rtol=0, atol=1e-12)


def test_the_implicit_integrator_steers_the_manipulator_like_the_explicit_one():
    spec, currents = _spec_and_currents()
    explicit = simulate_manipulator(spec, currents, ManipulatorRun(dt=0.01, n_samples=11, settle=0.01))
    implicit = simulate_manipulator(spec, currents, ManipulatorRun(dt=0.01, n_samples=11, settle=0.01,
                                                                   substeps=explicit.substeps,
                                                                   integrator="implicit"))
    assert ManipulatorRun(dt=0.01, n_samples=2, integrator="implicit").integrator == Implicit()
    moved = np.ptp(explicit.positions[:, -1], axis=0).max()
    assert moved > 1e-3
    assert np.abs(implicit.positions - explicit.positions).max() < 0.02 * moved
    assert np.allclose(implicit.currents, explicit.currents)


def test_a_batch_refuses_a_magnetic_load():
    spec, currents = _spec_and_currents()
    setup = manipulator_simulator(spec, currents, 1e-5).setup
    with pytest.raises(SoftrnnInputError, match="MagneticDipoles"):
        simulate_batch([setup], RunConfig(dt=0.01, n_samples=2))


def test_a_magnetic_load_is_checked():
    spec, _ = _spec_and_currents()
    held = CurrentSchedule(np.zeros(1), np.zeros((1, spec.coils.n_coils)))
    load = magnetic_load(spec, held)
    with pytest.raises(SoftrnnInputError, match="magnetic.currents"):
        load.with_currents(np.arange(2.0), np.zeros((3, spec.coils.n_coils)))
    with pytest.raises(SoftrnnInputError, match="magnetic.nodes"):
        MagneticDipoles(nodes=[-1], fractions=[0.5], moments=[[0, 0, 1.0]], source_positions=np.zeros((1, 3)),
                        source_moments=np.ones((1, 3)), times=[0.0], currents=[[0.0]])
