"""Scenario files: a simulation described in TOML and loaded into the frozen config classes of the
Python API (``RodSpec``, shapes, ``Clamp``/``Pin``, loads, ``Damping``, ``Setup``, ``RunConfig``).

A scenario names the rod, its reference (stress-free) and initial shapes, the boundary conditions,
the loads, damping and gravity, the saved interval and duration (or sample count), the solver
sub-steps, the nodes of interest and a seed, and optionally the rigid obstacles it touches
(``[contact]``); a ``[magnetic]`` table makes it describe the magnetic manipulator instead of a
plain rod (``softrnn.scenarios.magnetic``); an optional ``[randomize]`` table declares which values
a sweep varies and how (``Scenario.variant(i)``), and an optional ``[calibrate]`` table the bounds of
the values ``softrnn calibrate`` may fit (``Scenario.with_values`` builds a trial). The format is
documented in docs/scenario-format.md. The paper's cases and their generalisation variants ship inside the
package (``SCENARIO_NAMES``, files in ``softrnn/scenarios/``).

Every problem found on load is a one-line ``ScenarioError`` (a ``SoftrnnInputError``) that starts
with the file (or ``builtin:NAME``) and names the key and what was expected.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError, bad
from ..io.record import PDLaw, ScenarioRecord
from ..rod.boundary import Clamp
from ..rod.loads import PDTracking
from ..rod.simulation import RunConfig, Setup
from ._contact import read_contact
from ._hub import check_hub_run, read_hub, with_hub
from ._initial import initial_shape, with_static_start
from ._magnetic import check_magnetic_run, read_magnetic
from ._sections import _boundary, _gravity, _loads, _rod, _run, _shape, read_damping
from ._tendons import read_tendons
from .calibrate import _check_calibrate, _flatten_calibrate
from .magnetic import MagneticScenario
from .randomize import _flatten_randomize, _sample, _set_path
from .reading import ScenarioError, _as_is, _Ctx, _show, _Table, integer, string, table_list

SCENARIO_NAMES: tuple[str, ...] = ("ellipse", "ellipse-horizontal", "square", "square-circle", "square-figure8",
                                   "square-random", "semicircle", "semicircle-cosine", "tendon-planar",
                                   "tendon-planar-sine", "tendon-spatial", "tendon-spatial-sine",
                                   "tendon-displacement", "steel-wire", "nitinol-guidewire", "contact-plane",
                                   "vessel-guidewire", "contact-capstan", "magnetic-bifurcation",
                                   "vessel-guidewire-twist", "mesh-arch-guidewire",
                                   "mesh-arch-guidewire-1m")
FORMAT_VERSION = 1
BUILTIN_PREFIX = "builtin:"

_TOP_KEYS = {
    "format": f"the format version, {FORMAT_VERSION}",
    "name": "the scenario name",
    "title": "a one-line description",
    "seed": "an integer >= 0 for everything random in the scenario",
    "gravity": "gravity [gx, gy, gz] in m/s^2, or a profile table of it over time (kind = constant, ...; "
               "with a schedule)",
    "paper": "a table: section, key, dataset, role, note",
    "assumptions": "a table of named assumption texts",
    "rod": "the rod table: length, radius, youngs_modulus, density, n_nodes, ...",
    "reference": "the stress-free shape table (kind = straight, arc, ellipse or polyline)",
    "initial": "the initial shape table (default: the reference; kind = straight, arc, ellipse, polyline or "
               "poses, or from = static or dataset)",
    "boundary": "[[boundary]] entries (kind = clamp or pin)",
    "hub": "the hub table: node, entry, axis, insertion (or force, mass), rotation (or torque, inertia)",
    "loads": "[[loads]] entries (kind = force, torque or pd)",
    "tendons": "[[tendons]] entries: name, offset, routing, end_node or end_s, tension (or displacement and "
               "stiffness)",
    "damping": "the damping table: translational, rotational, kelvin_voigt",
    "contact": "the contact table: friction, ..., and [[contact.obstacles]] (kind = plane, sphere, cylinder, "
               "vessel or bifurcation)",
    "run": "the run table: dt, duration or n_samples, substeps, nodes_of_interest, ...",
    "randomize": "a table of dotted keys -> distributions for sweeps",
    "calibrate": "a table of dotted keys -> {bounds = [lo, hi], start = value} for softrnn calibrate",
    "magnetic": "the magnetic manipulator instead of a plain rod: field_mT or currents, start, ramp, settle, ...",
}


@dataclass(frozen=True, eq=False)
class Scenario:
    """A loaded scenario: the TOML ``text`` and its parsed ``data`` (for a variant: with the sampled
    values substituted), and what they build: ``setup``, ``config``, ``nodes_of_interest``.
    ``randomize`` maps dotted keys to their distributions, ``calibrate`` to (lower, upper, start or
    None) from the ``[calibrate]`` table. A scenario with a ``[magnetic]`` table has ``magnetic``
    (a ``MagneticScenario``: the manipulator and its currents; the one rod simulator runs it with the
    magnets' load, ``rod.magnetic.MagneticDipoles``), and its ``setup`` is the manipulator's rod
    problem without that load (``ManipulatorSpec.setup``)."""

    name: str
    title: str
    source: str
    text: str
    data: dict
    setup: Setup
    config: RunConfig
    nodes_of_interest: tuple[int, ...]
    seed: int
    paper: dict
    variant_index: int | None = None
    sampled: dict = field(default_factory=dict)
    assumptions: dict = field(default_factory=dict)
    randomize: dict = field(default_factory=dict, repr=False)
    calibrate: dict = field(default_factory=dict, repr=False)
    magnetic: MagneticScenario | None = field(default=None, repr=False)

    @property
    def record(self) -> ScenarioRecord:
        """What drives this scenario's run, as its data file stores it (``softrnn.io.record``): its name,
        nodes of interest, ``[paper]`` table, PD laws, moving clamps (a prescribed hub's too, not a
        driven one's), a variant's draws, obstacles."""
        pd = tuple(PDLaw(load.node, load.target, load.stiffness, load.damping)
                   for load in self.setup.loads if isinstance(load, PDTracking))
        moving = tuple(sorted(bc.node for bc in self.setup.boundary if isinstance(bc, Clamp) and bc.motion is not None
                              and not getattr(bc.motion, "driven", False)))   # a driven hub's node is no path
        return ScenarioRecord(name=self.name, nodes_of_interest=tuple(self.nodes_of_interest), paper=dict(self.paper),
                              pd=pd, moving_clamps=moving, sampled=dict(self.sampled),
                              variant_index=self.variant_index, contact=self.setup.contact)

    @property
    def randomized(self) -> bool:
        """Whether the scenario declares values to randomise (a ``[randomize]`` table)."""
        return bool(self.randomize)

    def variant(self, index: int) -> Scenario:
        """Variant ``index`` (>= 0): the base scenario with every ``[randomize]`` key drawn from its
        distribution, in the table's order, by ``numpy.random.default_rng([seed, index])``. The same
        scenario text, seed and index always give the same variant."""
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
            raise bad("variant index", index, "an integer >= 0")
        if not self.randomized:
            raise ScenarioError(self.source, "randomize",
                                "randomize: this scenario declares nothing to randomise (add a [randomize] table)")
        ctx = _Ctx(self.source, _base_for(self.source))
        doc = _parse_toml(ctx, self.text)
        data, sampled = _sample(ctx, doc, self.randomize, self.seed, int(index))
        try:
            return _build(ctx, self.text, data, variant_index=int(index), sampled=sampled)
        except ScenarioError as exc:
            raise ScenarioError(exc.source, exc.key, f"{str(exc)[len(exc.source) + 2:]} "
                                                     f"(variant {index}, sampled {_show(sampled)})") from None

    def with_values(self, values: dict) -> Scenario:
        """The scenario with each dotted key of ``values`` (as in ``[randomize]``) set to its value
        in a copy of the file's document (a variant's draws are not kept), built with the same
        validation as the file (a trial of ``softrnn calibrate``). ``sampled`` records the values;
        ``text`` stays the original."""
        ctx = _Ctx(self.source, _base_for(self.source))
        doc = _parse_toml(ctx, self.text)
        for key, value in values.items():
            _set_path(ctx, doc, key, value, table="calibrate")
        try:
            return _build(ctx, self.text, doc, sampled=dict(values))
        except ScenarioError as exc:
            raise ScenarioError(exc.source, exc.key, f"{str(exc)[len(exc.source) + 2:]} "
                                                     f"(with {_show(dict(values))})") from None


def _parse_toml(ctx: _Ctx, text: str) -> dict:
    """The TOML document of ``text``; malformed TOML is a ``ScenarioError``."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ctx.error("", f"malformed TOML: {exc}") from None


def _header(ctx: _Ctx, top: _Table) -> tuple[str, str, int, tuple, dict, dict]:
    """The top-level values: (name, title, seed, gravity in m/s^2 (a 3-vector or a time function),
    paper table, assumptions table)."""
    fmt = top.get("format", integer(), FORMAT_VERSION)
    if fmt != FORMAT_VERSION:
        raise ctx.invalid("format", fmt, f"{FORMAT_VERSION} (the format this softrnn reads)")
    default_name = ctx.source[len(BUILTIN_PREFIX):] if ctx.source.startswith(BUILTIN_PREFIX) else Path(ctx.source).stem
    name = top.get("name", string(), default_name)
    if not name.strip():
        raise ctx.invalid("name", name, "a non-empty name")
    title = top.get("title", string(), name)
    seed = top.get("seed", integer(0, "an integer >= 0"), 0)
    gravity = top.get("gravity", _gravity, (0.0, 0.0, 0.0))
    paper = top.get("paper", _as_is, {})
    pt = _Table(ctx, paper, "paper", {"section": "the paper's section, e.g. \"4.2\"",
                                      "key": "the key of the paper's results (softrnn/data/paper_results.json)",
                                      "dataset": "the paper's data-set name",
                                      "role": "\"training\" or \"generalisation\"", "note": "free text"})
    for k in pt.raw:
        pt.get(k, string())
    assumptions = top.get("assumptions", _as_is, {})
    at = _Table(ctx, assumptions, "assumptions",
                {k: "text" for k in assumptions} if isinstance(assumptions, dict) else {})
    for k in at.raw:
        at.get(k, string())
    return name, title, seed, gravity, paper, assumptions


def _setup(ctx: _Ctx, top: _Table, doc: dict, gravity: tuple) -> Setup:
    """The rod, its shapes, boundary conditions, loads, tendons and damping as a ``Setup``."""
    rod = _rod(ctx, top.raw_value("rod"))
    reference = _shape(ctx, top.raw_value("reference"), "reference", rod)
    initial = initial_shape(ctx, doc["initial"], rod) if "initial" in doc else None
    if initial is not None:
        arc_len = initial.arc_length()
        if abs(arc_len / rod.length - 1.0) > 0.05:
            raise ctx.invalid("initial", f"a shape of arc length {arc_len:.4g} m",
                              f"an initial shape within 5% of rod.length = {rod.length:.4g} m "
                              "(the rod would start stretched; use fit_length = true for an ellipse)")
    start = initial if initial is not None else reference
    boundary = _boundary(ctx, top.get("boundary", table_list, []), start, rod.n_nodes)
    if "hub" in doc:
        boundary = with_hub(ctx, boundary, read_hub(ctx, doc["hub"], start, rod.n_nodes))
    loads = _loads(ctx, top.get("loads", table_list, []), rod.n_nodes)
    tendons = read_tendons(ctx, top.get("tendons", table_list, []), rod)
    damping = read_damping(ctx, top.get("damping", _as_is, {}))
    contact = read_contact(ctx, doc["contact"]) if "contact" in doc else None
    try:
        setup = Setup(rod=rod, reference=reference, initial=initial, boundary=boundary, loads=loads,
                      damping=damping, gravity=gravity, tendons=tendons, contact=contact)
    except SoftrnnInputError as exc:
        raise ctx.wrap(_setup_key(str(exc)), exc) from None
    return with_static_start(ctx, doc, setup)


def _setup_key(message: str) -> str:
    """The key a ``Setup`` validation error points to: contact, reference or setup."""
    if "contact" in message or "obstacle" in message:
        return "contact"
    return "reference" if "reference" in message else "setup"


def _build(ctx: _Ctx, text: str, doc: dict, variant_index: int | None = None, sampled: dict | None = None) -> Scenario:
    """The ``Scenario`` of the TOML document ``doc`` (parsed from ``text``), every value checked."""
    top = _Table(ctx, doc, "", _TOP_KEYS)
    name, title, seed, gravity, paper, assumptions = _header(ctx, top)
    magnetic = read_magnetic(ctx, doc, gravity) if "magnetic" in doc else None
    if magnetic is not None:
        setup = magnetic.spec.setup()
        check_magnetic_run(ctx, doc.get("run"))
    else:
        setup = _setup(ctx, top, doc, gravity)
    config, interest = _run(ctx, top.raw_value("run"), setup.rod, setup.damping)
    check_hub_run(ctx, setup, config)
    randomize = _flatten_randomize(ctx, top.get("randomize", _as_is, {}))
    calibrate = _flatten_calibrate(ctx, top.get("calibrate", _as_is, {}))
    return Scenario(name=name, title=title, source=ctx.source, text=text, data=doc, setup=setup, config=config,
                    nodes_of_interest=interest, seed=seed, paper=dict(paper), variant_index=variant_index,
                    sampled=dict(sampled or {}), assumptions=dict(assumptions), randomize=randomize,
                    calibrate=calibrate, magnetic=magnetic)


def _builtin_dir():
    """The folder of the shipped scenario files."""
    return resources.files("softrnn").joinpath("scenarios")


def _base_for(source: str):
    """The folder relative file names in a scenario are read from."""
    if source.startswith(BUILTIN_PREFIX):
        return _builtin_dir()
    if source.startswith("<"):
        return Path.cwd()
    return Path(source).parent


def parse_scenario(text: str, source: str = "<string>") -> Scenario:
    """A scenario from TOML ``text``; ``source`` (a path, ``builtin:NAME`` or ``<string>``) prefixes
    every error and locates relative file names. A randomised scenario also builds its variant 0 as
    a check, so a bad ``[randomize]`` key is reported on load; every ``[calibrate]`` key must name a
    number whose bounds hold its start."""
    if not isinstance(text, str):
        raise bad("text", type(text).__name__, "the TOML text as a str")
    ctx = _Ctx(str(source), _base_for(str(source)))
    doc = _parse_toml(ctx, text)
    scenario = _build(ctx, text, doc)
    starts = _check_calibrate(ctx, doc, scenario.calibrate)
    if starts:
        scenario.with_values({key: start for key, (_, _, start) in starts.items()})
    if scenario.randomized:
        scenario.variant(0)
    return scenario


def scenario_text(name: str) -> str:
    """The TOML text of a shipped scenario."""
    if name not in SCENARIO_NAMES:
        raise bad("scenario", name, f"one of {', '.join(SCENARIO_NAMES)}, or a path to a .toml file")
    return _builtin_dir().joinpath(f"{name}.toml").read_text(encoding="utf-8")


def load_scenario(name_or_path) -> Scenario:
    """A shipped scenario by name (``SCENARIO_NAMES``) or a scenario file by path."""
    s = str(name_or_path)
    if s in SCENARIO_NAMES and not isinstance(name_or_path, Path):
        return parse_scenario(scenario_text(s), BUILTIN_PREFIX + s)
    path = Path(s)
    if path.is_file():
        try:
            text = path.read_bytes().decode("utf-8")
        except OSError as exc:
            raise ScenarioError(s, "", f"cannot read the file: {exc.strerror or exc}") from None
        except UnicodeDecodeError:
            raise ScenarioError(s, "", "malformed TOML: the file is not UTF-8 text") from None
        return parse_scenario(text, s)
    if path.suffix == ".toml" or "/" in s or "\\" in s:
        raise bad("scenario", s, "an existing .toml file (no such file)" if not path.exists()
                  else "a .toml file, not a folder")
    raise bad("scenario", s, f"one of {', '.join(SCENARIO_NAMES)}, or a path to a .toml file")
