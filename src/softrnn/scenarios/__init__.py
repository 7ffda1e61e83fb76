"""Scenarios: the TOML files shipped beside this module (the paper's cases and their
generalisation variants), their loading and validation, the target paths they name, the paper's
cases built from them, and the summary of a scenario's run.

* ``scenario``: ``load_scenario``, ``parse_scenario``, ``Scenario`` (and its ``variant`` for sweeps);
* ``paths``: target and motion paths (figure-8, random smooth, pose motions);
* ``cases``: the paper's Data-sets I-III as ``Case`` records and their ``ASSUMPTIONS``;
* ``summary``: ``simulate_summary``, the run behind ``softrnn simulate``, and ``contact_lines``, the
  obstacles in a scenario's summary;
* ``record``: the scenario record of a data set written before the record existed, rebuilt from its
  text (``with_record``; registered at import as ``softrnn.io.record``'s record builder, so that
  ``read_record`` reads old files); a scenario's own is ``Scenario.record``;
* ``magnetic``: magnetic scenarios (a ``[magnetic]`` table): ``MagneticScenario``, the manipulator
  (a rod with the magnets' load, ``softrnn.rod.magnetic.MagneticDipoles``) run by the one rod
  simulator (``simulate_magnetic``) and written with the coil currents;
* ``suite``: the suite file of ``softrnn lab benchmark --suite`` (``read_suite``: robots, their sessions
  and options; run by ``softrnn.lab.suite``).
"""

from . import record as _record  # noqa: F401  (registers the record builder of old data files)
from .reading import ScenarioError as ScenarioError
from .scenario import SCENARIO_NAMES as SCENARIO_NAMES
from .scenario import Scenario as Scenario
from .scenario import load_scenario as load_scenario
from .scenario import parse_scenario as parse_scenario
from .scenario import scenario_text as scenario_text
from .suite import read_suite as read_suite
