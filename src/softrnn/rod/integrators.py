"""The solver integrators a ``RunConfig`` runs: ``Explicit`` (the LGVI step of ``rod.kernels``) and
``Implicit`` (the stiff-stable step of ``rod.implicit``, docs/lgvi.md §8).

Each is a frozen, validated value that carries its options and owns what differs between the two:
the choice of substeps, the start at rest (half kick), the stepping of a chunk and the advice a run
too large for the machine gets. ``Simulator`` calls them and holds no branch of its own; they read
the simulator's lumped rod, inputs and setup (``sim.rod``, ``sim.inputs``, ``sim.setup``).
"""

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import bad
from . import implicit, kernels
from .contact import step_limit
from .discrete import segment_strains
from .state import empty_samples, half_kick
from .status import raise_for_status


def choose_substeps(config, limit: float) -> int:
    """Solver steps per saved interval of ``config`` (a ``RunConfig``) for the stable step ``limit``
    [s]: the fewest stable ones, or ``config.substeps``, refused if unstable."""
    if config.substeps is None:
        return max(1, math.ceil(config.dt / limit * (1 - 1e-12)))
    h = config.dt / config.substeps
    if h > limit:
        need = math.ceil(config.dt / limit)
        raise bad("dt", config.dt,
                  f"dt/substeps = {h:.3g} s exceeds the stable step limit {limit:.3g} s of this rod; "
                  f"use substeps >= {need} (or substeps=None to choose it automatically)")
    return int(config.substeps)


@dataclass(frozen=True)
class Explicit:
    """The explicit LGVI step (``rod.kernels.advance``): substeps None gives the fewest stable ones,
    and an unstable choice is refused."""

    name: ClassVar[str] = "explicit"

    def __str__(self) -> str:
        return self.name

    @property
    def step_advice(self) -> str | None:
        """What a run with too many solver steps may switch to (``check_run_size``)."""
        return ("the implicit integrator, whose step does not shrink with the rod's stiffness "
                "(--integrator implicit on the command line, run.integrator in a scenario file, or "
                "RunConfig(integrator=\"implicit\") in Python)")

    def resolve_substeps(self, sim, config) -> int:
        """Solver steps per saved interval of ``config`` for the simulator ``sim``."""
        return choose_substeps(config, sim.stable_step(config.safety))

    def half_kick(self, sim, inputs, h: float) -> None:
        """Start ``sim.state`` (at rest) to second order (``rod.state.half_kick``)."""
        half_kick(sim.rod, sim.state, inputs, h)

    def advance(self, sim, st, inputs, out, h, k0, n_steps, stride, s0) -> tuple[int, int]:
        """Steps k0 .. k0 + n_steps - 1 of ``st`` (a ``RodState``) into ``out``; (status, step)."""
        return kernels.advance(sim.rod, st.arrays(), inputs, out, h, k0, n_steps, stride, s0)


@dataclass(frozen=True)
class Implicit:
    """The stiff-stable step (``rod.implicit``): any step is stable for the rod's own stiffness, and
    substeps None resolves its fourth bending mode (``rod.implicit.accuracy_step``); a given substeps
    is never refused.

    Attributes
    ----------
    beta : float
        Newmark weight of the implicit stiffness, >= 1/4 (docs/lgvi.md §8)
    theta : float
        weight in [0, 1] of the previous velocities in the implicit force (1: the scheme of §8)
    """

    beta: float = implicit.IMPLICIT_BETA
    theta: float = implicit.IMPLICIT_THETA
    name: ClassVar[str] = "implicit"

    def __post_init__(self):
        if isinstance(self.beta, bool) or not isinstance(self.beta, (int, float)) or not self.beta >= 0.25 \
                or not math.isfinite(self.beta):
            raise bad("integrator.beta", self.beta, "a finite Newmark weight >= 0.25 (0.5 by default)")
        if isinstance(self.theta, bool) or not isinstance(self.theta, (int, float)) or not 0 <= self.theta <= 1:
            raise bad("integrator.theta", self.theta, "a weight in [0, 1] (1 by default)")
        object.__setattr__(self, "beta", float(self.beta))
        object.__setattr__(self, "theta", float(self.theta))

    def __str__(self) -> str:
        return self.name

    step_advice = None
    """Nothing to switch to when a run has too many solver steps."""

    def resolve_substeps(self, sim, config) -> int:
        """``config.substeps`` as given, or the steps that resolve the rod's bending modes and keep
        the explicit contact loads stable (not bounded by linearly implicit contact, ``Contact.implicit``)."""
        if config.substeps is not None:
            return int(config.substeps)
        limit = implicit.accuracy_step(sim.rod, sim.inputs.pd_gain, config.safety)
        if sim.inputs.contact is not None and not sim.setup.contact.implicit:  # explicit contact loads
            limit = min(limit, config.safety * step_limit(sim.inputs.contact["contact_node"], sim.rod.mass))
        return max(1, math.ceil(config.dt / limit * (1 - 1e-12)))

    def half_kick(self, sim, inputs, h: float) -> None:
        """Start ``sim.state`` (at rest) to second order: -u/2 of one implicit step from rest."""
        work, tau = sim.implicit_work(), sim.setup.damping.kelvin_voigt
        out = empty_samples(np.full(sim.setup.rod.n_nodes, -1, dtype=np.int64), 1, 0)
        code, _ = implicit.advance_implicit_into(sim.elastic_rod, sim.state.arrays(), inputs, out, h, 0,
                                                 implicit.HALF_KICK, 1, 0, work, self.beta, self.theta, tau)
        raise_for_status(code, step=0, t0=sim.state.time, h=h)

    def advance(self, sim, st, inputs, out, h, k0, n_steps, stride, s0) -> tuple[int, int]:
        """Steps k0 .. k0 + n_steps - 1 of ``st`` (a ``RodState``) into ``out``; (status, step)."""
        work = sim.implicit_work()
        code, step = implicit.advance_implicit_into(sim.elastic_rod, st.arrays(), inputs, out, h, k0, n_steps,
                                                    stride, s0, work, self.beta, self.theta,
                                                    sim.setup.damping.kelvin_voigt)
        if sim.rod.kv_on:
            # the explicit step's Kelvin-Voigt memory, for a later explicit run of this simulator
            st.prev_curvature[:], st.prev_shear[:] = segment_strains(st.rotations, st.positions, sim.rod.length)
        return code, step


BY_NAME = {"explicit": Explicit, "implicit": Implicit}
"""The integrators by name (a scenario's ``run.integrator``, ``--integrator``), each with its defaults."""


def as_integrator(value) -> Explicit | Implicit:
    """An integrator from an ``Explicit``/``Implicit`` value or its name; a one-line error otherwise."""
    if isinstance(value, (Explicit, Implicit)):
        return value
    if isinstance(value, str) and value in BY_NAME:
        return BY_NAME[value]()
    raise bad("integrator", value, "Explicit(), Implicit(beta=..., theta=...) (softrnn.rod.integrators) or "
                                   + " or ".join(repr(i) for i in BY_NAME))
