"""Magnetic scenarios: a scenario with a ``[magnetic]`` table describes the magnetic manipulator
(``softrnn.magnetics.ManipulatorSpec``: a clamped rod with two embedded magnets, driven by coil
currents) instead of a plain rod; ``softrnn simulate``, ``sweep`` and ``animate`` run it as the
manipulator (``simulate_magnetic``: ``simulate_manipulator``, a rod ``Simulator`` run with the
magnetic load) and store it as a dataset with the coil currents as actuation channels
(``write_manipulator_dataset``, also behind ``softrnn magnetic navigate``). The table is documented
in docs/scenario-format.md.
"""

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import bad
from ..io.writer import write_trajectory
from ..magnetics.manipulator import (
    CurrentSchedule,
    ManipulatorRun,
    ManipulatorSpec,
    ManipulatorTrajectory,
    check_manipulator_run,
    simulate_manipulator,
)
from ..magnetics.navigation import ramp_schedule, tip_branch
from ..progress import Progress
from ..rod import RunConfig
from ..rod.contact import Bifurcation
from ..rod.so3 import quaternion_to_matrix


@dataclass(frozen=True, eq=False)
class MagneticScenario:
    """What a ``[magnetic]`` table builds: the manipulator and how its coils are driven.

    Attributes
    ----------
    spec : ManipulatorSpec
        the manipulator (with the scenario's contact, gravity and damping)
    currents : numpy.ndarray (n_c,)
        the held coil currents [A]
    field : numpy.ndarray (3,) or None
        the field [T] the currents make at the workspace centre (``field_mT``), or None when the
        scenario gives the currents
    start, ramp : float
        the currents are zero until ``start`` [s], then rise linearly over ``ramp`` [s] and hold
    settle : float
        settling [s] at zero current (heavy drag) before t = 0
    """

    spec: ManipulatorSpec
    currents: np.ndarray
    field: np.ndarray | None = None
    start: float = 0.0
    ramp: float = 0.5
    settle: float = 0.3

    def __post_init__(self):
        if not isinstance(self.spec, ManipulatorSpec):
            raise bad("spec", type(self.spec).__name__, "a softrnn.magnetics.ManipulatorSpec")
        currents = np.array(self.spec.coils.check_currents(self.currents, "currents"), dtype=float)
        if currents.ndim != 1:
            raise bad("currents.shape", currents.shape, f"({self.spec.coils.n_coils},): one current per coil")
        currents.setflags(write=False)
        object.__setattr__(self, "currents", currents)
        if self.field is not None:
            b = np.array(self.field, dtype=float)
            if b.shape != (3,) or not np.all(np.isfinite(b)):
                raise bad("field", self.field, "a finite 3-vector in T, or None")
            b.setflags(write=False)
            object.__setattr__(self, "field", b)
        for name, low in (("start", 0.0), ("settle", 0.0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value < low:
                raise bad(name, value, "a time >= 0 in s")
        if isinstance(self.ramp, bool) or not isinstance(self.ramp, (int, float)) or not math.isfinite(self.ramp) \
                or self.ramp <= 0:
            raise bad("ramp", self.ramp, "a rise time > 0 in s")

    def schedule(self, end: float) -> CurrentSchedule:
        """The coil currents over a run that ends at ``end`` [s] (``ramp_schedule``)."""
        return ramp_schedule(self.currents, self.ramp, end, self.start)

    def run(self, config: RunConfig) -> ManipulatorRun:
        """The manipulator's run for the scenario's ``RunConfig``: its dt, samples, substeps, safety
        and integrator, with this scenario's settling."""
        return ManipulatorRun(dt=config.dt, n_samples=config.n_samples, substeps=config.substeps,
                              safety=config.safety, settle=self.settle, integrator=config.integrator)

    def check_size(self, config: RunConfig) -> None:
        """Refuse a run of ``config`` too large for this machine (``check_manipulator_run``: the
        manipulator holds every sample), with a one-line error."""
        check_manipulator_run(self.spec, self.run(config))


def simulate_magnetic(magnetic: MagneticScenario, config: RunConfig,
                      progress: Progress | None = None) -> ManipulatorTrajectory:
    """Run a magnetic scenario as a manipulator run (``simulate_manipulator``).

    Parameters
    ----------
    magnetic : MagneticScenario
        the scenario's manipulator and currents (``Scenario.magnetic``)
    config : RunConfig
        the saved interval, samples, substeps, safety and integrator (``Scenario.config``)
    progress : softrnn.progress.Progress or None
        as for ``simulate_manipulator``

    Returns
    -------
    ManipulatorTrajectory
        every node at every saved sample, the coil currents and the magnets' quantities
    """
    run = magnetic.run(config)
    return simulate_manipulator(magnetic.spec, magnetic.schedule(run.duration), run, progress=progress)


def bifurcation_of(spec: ManipulatorSpec) -> Bifurcation | None:
    """The one ``Bifurcation`` among the obstacles of ``spec.contact``, or None (none, or several)."""
    found = [] if spec.contact is None else [o for o in spec.contact.obstacles if isinstance(o, Bifurcation)]
    return found[0] if len(found) == 1 else None


def write_manipulator_dataset(path, traj: ManipulatorTrajectory, spec: ManipulatorSpec, *, dt: float,
                              attrs: dict | None = None, scenario_text: str = "", seed: int | None = None,
                              record=None) -> None:
    """Write a manipulator run to the HDF5 dataset ``path`` (atomically): every node, the coil
    currents as the actuation channels ``coil_<k>`` [A], with contact the obstacles and the
    contact loads, and the scenario record ``record`` (``Scenario.record``; None: none).

    Parameters
    ----------
    path : str or Path
        the dataset to write
    traj : ManipulatorTrajectory
        the run
    spec : ManipulatorSpec
        the manipulator that made it (its rod, with the magnet segments, and its contact)
    dt : float
        the saved interval [s]
    attrs, scenario_text, seed : dict or None, str, int or None
        extra attributes stored with the dataset, the scenario's TOML text ("" for none) and seed
    record : softrnn.io.record.ScenarioRecord or None
        what drove the run (with ``spec.advance`` node 0 in its ``moving_clamps``), stored as the
        attribute ``scenario_record``; None: none stored
    """
    write_trajectory(path, traj.rod, dt=dt, rod=spec.rod_spec(), scenario_text=scenario_text, seed=seed,
                     attrs=attrs, actuation_units={f"coil_{k}": "A" for k in range(traj.currents.shape[1])},
                     actuation=traj.currents, contact=spec.contact, record=record)


def magnetic_summary(*, name: str, title: str, magnetic: MagneticScenario, config: RunConfig, node: int,
                     out_path=None, scenario_text: str = "", seed: int | None = None, attrs: dict | None = None,
                     progress: Progress | None = None, series: dict | None = None, record=None) -> dict:
    """Simulate a magnetic scenario and summarise it as ``simulate_summary`` does (same keys, plus
    ``tip_branch`` and the held ``currents_a``); with ``out_path`` write the dataset
    (``write_manipulator_dataset``, with the attribute ``tip_branch`` where the obstacles hold one
    bifurcation, and the scenario record ``record``). Parameters are those of ``simulate_summary``,
    with ``magnetic`` the scenario's ``MagneticScenario`` in place of the setup; returns the
    JSON-ready summary."""
    spec = magnetic.spec
    node = spec.setup().node_index(node, "node of interest")
    start = time.perf_counter()
    traj = simulate_magnetic(magnetic, config, progress=progress)
    bif = bifurcation_of(spec)
    where = None if bif is None else tip_branch(bif, traj.positions[-1, -1])
    if out_path is not None:
        extra = {} if where is None else {"tip_branch": where}
        write_manipulator_dataset(out_path, traj, spec, dt=config.dt, attrs={**(attrs or {}), **extra},
                                  scenario_text=scenario_text, seed=seed, record=record)
    total = time.perf_counter() - start
    p = traj.positions[:, node]
    energy = traj.rod.energy
    if series is not None:
        series.update(time=np.array(traj.time), node_positions=np.array(p), energy=np.array(energy))
    R = quaternion_to_matrix(traj.quaternions[-1])
    simulated = float(traj.time[-1])
    steps = (config.n_samples - 1) * traj.substeps + 1
    return {
        "case": name, "title": title, "length_m": spec.length, "radius_m": 0.5 * spec.diameter,
        "youngs_modulus_pa": spec.youngs_modulus, "n_nodes": spec.n_nodes, "n_samples": config.n_samples,
        "dt_s": config.dt, "duration_s": simulated, "integrator": config.integrator.name, "step_s": traj.step,
        "substeps": traj.substeps, "stable_step_s": spec.stable_step(config.safety),
        "wall_time_s": traj.wall_time, "total_time_s": total,
        "us_per_node_step": 1e6 * traj.wall_time / (steps * spec.n_nodes),
        "realtime_factor": simulated / traj.wall_time if traj.wall_time > 0 else float("inf"),
        "node": node, "node_start_m": p[0].tolist(), "node_min_m": p.min(0).tolist(),
        "node_max_m": p.max(0).tolist(), "energy_start_j": float(energy[0].sum()),
        "energy_end_j": float(energy[-1].sum()),
        "max_orthogonality_error": float(np.max(np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)))),
        "output": None if out_path is None else str(out_path), "saved_nodes": spec.n_nodes,
        "tip_branch": where, "currents_a": magnetic.currents.tolist(),
    }
