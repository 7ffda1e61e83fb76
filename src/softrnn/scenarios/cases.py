"""The paper's three simulated cases (Tariverdi et al. 2021, section 4) and their variants.

Every case is a scenario file shipped in ``softrnn/scenarios/`` (``softrnn.scenarios.scenario``): the values
the paper gives, and every value it leaves out with its reason, live there, as TOML comments and in
each file's ``[assumptions]`` table. ``ASSUMPTIONS`` collects those tables of the paper's training
cases (reports quote it). Node numbers are 0-based.
"""

from dataclasses import dataclass, field, replace

from ..errors import bad
from ..rod import RunConfig, Setup
from .scenario import SCENARIO_NAMES, Scenario, load_scenario

CASE_NAMES = SCENARIO_NAMES
PAPER_CASES = ("ellipse", "square", "semicircle")


@dataclass(frozen=True)
class Case:
    """A named simulation: its setup, how to run it, the node of interest and its provenance
    (``scenario``: the scenario it was built from)."""

    name: str
    title: str
    setup: Setup
    config: RunConfig
    node_of_interest: int
    paper_key: str
    paper_section: str
    scenario: Scenario | None = field(default=None, compare=False, repr=False)


def _collect_assumptions() -> dict:
    out: dict = {}
    for name in PAPER_CASES:
        out.update(load_scenario(name).assumptions)
    return out


ASSUMPTIONS = _collect_assumptions()


def case_from_scenario(scenario: Scenario) -> Case:
    """The Case view of a scenario (its first node of interest, its [paper] table)."""
    return Case(scenario.name, scenario.title, scenario.setup, scenario.config,
                node_of_interest=scenario.nodes_of_interest[0], paper_key=scenario.paper.get("key", ""),
                paper_section=scenario.paper.get("section", ""), scenario=scenario)


def build_case(name: str) -> Case:
    """The named case (a shipped scenario); raises SoftrnnInputError for an unknown name."""
    if name not in CASE_NAMES:
        raise bad("case", name, f"one of {', '.join(CASE_NAMES)}")
    return case_from_scenario(load_scenario(name))


def with_overrides(case: Case, *, rod: dict | None = None, dt: float | None = None) -> Case:
    """The case with rod properties (RodSpec field names) and/or the saved interval replaced;
    the new values are validated like any RodSpec / RunConfig."""
    setup = case.setup
    if rod:
        setup = replace(setup, rod=replace(setup.rod, **rod))
    config = case.config if dt is None else replace(case.config, dt=dt)
    return replace(case, setup=setup, config=config)
