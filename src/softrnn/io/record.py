"""The record of what drove a simulated trajectory, stored with it: the scenario's name, its nodes of
interest and ``[paper]`` table, its PD laws with their targets, the clamps it moves along a path, a
sweep variant's draws, and its obstacles (docs/dataset-format.md#the-scenario-record).

``softrnn.scenarios`` writes it at simulation time (``Scenario.record``, passed to the writer as
``record``); every reader of a data file's scenario reads it here, through ``read_record``, typed,
and never parses the scenario's text. A file written before the record existed has none stored:
``read_record`` then asks the record builder registered with ``set_record_builder`` (importing
``softrnn.scenarios`` registers one that rebuilds the record from the stored scenario text, so every
CLI command reads old files as before); without a builder, or for lab data, it gives None, and a
feature that needs the record says so (``softrnn.scenarios.record`` adds it to such a file).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import bad, is_finite_number
from ..geometry.contact import Contact, contact_from_record, contact_record
from ..geometry.paths import function_from_record, function_record

RECORD = "scenario_record"
"""Name of the group attribute (JSON) and of the ``Dataset.attrs`` key holding the record."""

RECORD_VERSION = 1
"""Version of the record's own layout (its ``version`` key); readers refuse a newer one."""

_builder = None
"""The record builder of ``set_record_builder`` (None: none registered)."""


@dataclass(frozen=True, eq=False)
class PDLaw:
    """A PD tracking law: f = stiffness (target(t) - r) - damping v [N] on ``node``.

    Attributes
    ----------
    node : int
        the node (0-based, counted from the rod's start)
    target : callable
        its target, a time function of ``softrnn.geometry.paths``: t (K,) [s] -> (K, 3) [m]
    stiffness : float
        the P gain [N/m]
    damping : float
        the D gain [N s/m]
    """

    node: int
    target: object
    stiffness: float
    damping: float = 0.0

    def to_record(self) -> dict:
        """The law as JSON-ready values (its target as ``function_record`` gives it)."""
        return {"node": int(self.node), "target": function_record(self.target),
                "stiffness": float(self.stiffness), "damping": float(self.damping)}

    @staticmethod
    def from_record(record) -> PDLaw:
        """The law of a record (``to_record``); a malformed one is a one-line error."""
        if not isinstance(record, dict) or not isinstance(record.get("node"), int) or not all(
                is_finite_number(record.get(k)) for k in ("stiffness", "damping")):
            raise bad("scenario_record.pd", record, "{node: int, target: {...}, stiffness: N/m, damping: N s/m}")
        return PDLaw(record["node"], function_from_record(record.get("target")), float(record["stiffness"]),
                     float(record["damping"]))


@dataclass(frozen=True, eq=False)
class ScenarioRecord:
    """What drove a simulated trajectory (see the module docstring).

    Attributes
    ----------
    name : str
        the scenario's name
    nodes_of_interest : tuple of int
        its nodes of interest (0-based)
    paper : dict
        its ``[paper]`` table ({} without one): ``key``, ``role``, ``section``, ... (strings)
    pd : tuple of PDLaw
        its PD tracking laws, a sweep variant's draws in them
    moving_clamps : tuple of int
        the clamped nodes (0-based, increasing) it moves along a prescribed path
    sampled : dict
        a sweep variant's draws {dotted key: value} ({} for the scenario itself)
    variant_index : int or None
        the sweep variant's index (None for the scenario itself)
    contact : Contact or None
        its obstacles and contact law (None without; the same as the ``contact`` attribute of a
        trajectory with contact loads, kept here too so that a prediction of it keeps them)
    """

    name: str
    nodes_of_interest: tuple = ()
    paper: dict = field(default_factory=dict)
    pd: tuple = ()
    moving_clamps: tuple = ()
    sampled: dict = field(default_factory=dict)
    variant_index: int | None = None
    contact: Contact | None = None

    def to_record(self) -> dict:
        """The record as JSON-ready values (``contact`` as ``contact_record`` gives it)."""
        return {"version": RECORD_VERSION, "name": self.name,
                "nodes_of_interest": [int(a) for a in self.nodes_of_interest], "paper": dict(self.paper),
                "pd": [law.to_record() for law in self.pd], "moving_clamps": [int(a) for a in self.moving_clamps],
                "sampled": dict(self.sampled), "variant_index": self.variant_index,
                "contact": contact_record(self.contact)}

    @staticmethod
    def from_record(record) -> ScenarioRecord:
        """The record of its JSON values (``to_record``); a malformed one is a one-line
        ``SoftrnnInputError``."""
        if not isinstance(record, dict) or not isinstance(record.get("name"), str):
            raise bad("scenario_record", _short(record), "a dict with the scenario's name (see ScenarioRecord)")
        version = record.get("version")
        if not isinstance(version, int) or not 1 <= version <= RECORD_VERSION:
            raise bad("scenario_record.version", version, f"1..{RECORD_VERSION} (a newer softrnn wrote it: upgrade)")
        lists = {key: record.get(key, []) for key in ("nodes_of_interest", "pd", "moving_clamps")}
        if not all(isinstance(v, list) for v in lists.values()) or not all(
                isinstance(a, int) for key in ("nodes_of_interest", "moving_clamps") for a in lists[key]):
            raise bad("scenario_record", _short(record), "lists nodes_of_interest, pd and moving_clamps")
        index = record.get("variant_index")
        if index is not None and not isinstance(index, int):
            raise bad("scenario_record.variant_index", index, "an integer or null")
        contact = record.get("contact")
        contact = None if contact is None else contact_from_record(contact)
        return ScenarioRecord(name=record["name"], nodes_of_interest=tuple(lists["nodes_of_interest"]),
                              paper=dict(record.get("paper") or {}),
                              pd=tuple(PDLaw.from_record(law) for law in lists["pd"]),
                              moving_clamps=tuple(lists["moving_clamps"]), sampled=dict(record.get("sampled") or {}),
                              variant_index=index, contact=contact)


def set_record_builder(builder):
    """Register ``builder`` (attrs dict -> ``ScenarioRecord`` or None; None: unregister) as the
    fallback of ``read_record`` for a data set that stores no record but its scenario text (a file
    written before the record existed). ``softrnn.scenarios`` registers its own at import (this
    package may not import it). Returns the builder registered before."""
    global _builder
    if builder is not None and not callable(builder):
        raise bad("builder", type(builder).__name__, "a callable attrs -> ScenarioRecord or None, or None")
    previous, _builder = _builder, builder
    return previous


def read_record(data) -> ScenarioRecord | None:
    """The record of a data set (a ``Dataset``, anything with ``attrs``, or an attrs dict): the stored
    one; without one, that of the registered builder (``set_record_builder``) from its scenario
    text; None where neither gives one (lab data; an old file without a builder registered)."""
    attrs = data if isinstance(data, dict) else dict(getattr(data, "attrs", None) or {})
    raw = attrs.get(RECORD)
    if raw is not None:
        return ScenarioRecord.from_record(raw)
    if _builder is None or not isinstance(attrs.get("scenario_text"), str):
        return None
    record = _builder(attrs)
    if record is not None and not isinstance(record, ScenarioRecord):
        raise bad("record builder", type(record).__name__, "a ScenarioRecord or None")
    return record


def scenario_name(data) -> str | None:
    """The name of the scenario behind a data set: the ``scenario_name`` or ``case`` its writer put in
    its attrs, else its record's; None without any."""
    attrs = data if isinstance(data, dict) else dict(getattr(data, "attrs", None) or {})
    for key in ("scenario_name", "case"):
        if isinstance(attrs.get(key), str) and attrs[key]:
            return attrs[key]
    record = read_record(attrs)
    return record.name if record is not None else None


def _short(value):
    """``value``, or the start of its text where that is long (for error messages)."""
    text = repr(value)
    return value if len(text) <= 80 else text[:70] + " ..."
