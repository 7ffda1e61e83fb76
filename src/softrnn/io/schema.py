"""The HDF5 file format of a trajectory, schemas 2 and 3: constants, units, the error type and shared helpers.

The format is documented in docs/dataset-format.md.

One trajectory is a group (the file's root, or ``/traj-00000`` ... in a sweep file) holding

========== ============ ======= =====================================================
dataset    shape        dtype   meaning
========== ============ ======= =====================================================
time       (T,)         float64 sample times [s], strictly increasing
nodes      (N,)         int64   0-based rod node index of each stored column
positions  (T, N, 3)    float32 node positions [m], world frame
quaternions(T, N, 4)    float32 unit quaternions (w, x, y, z), body -> world
forces     (T, N, 3)    float32 applied external forces [N], world frame
torques    (T, N, 3)    float32 applied external torques [N m], world frame
actuation  (T, m)       float32 optional: named actuation inputs (tendon tensions, chamber
                                pressures, coil currents, a hub's insertion and rotation:
                                ``HUB_CHANNELS``, ...), one column per channel, with the
                                attributes ``names`` and ``units`` (JSON lists of m strings)
contact_forces (T, N, 3) float32 optional (schema 3): contact forces of the obstacles [N], world
contact_torques (T, N, 3) float32 optional (schema 3): their torques about the nodes [N m], world
========== ============ ======= =====================================================

and the attributes ``softrnn_schema``, ``softrnn_version``, ``dt``, ``seed`` (absent when there is
none), ``rod`` (JSON), ``scenario`` (text), ``units`` (JSON), ``n_nodes_total`` and ``attrs`` (JSON,
the caller's own metadata), and with the contact datasets ``contact`` (JSON: the obstacles, see
``softrnn.geometry.contact.contact_record``), and, for a simulated scenario, ``scenario_record``
(JSON: what drove the run, ``softrnn.io.record``). The per-node arrays are chunked ``(TIME_CHUNK, 1, c)`` and compressed
(gzip level 4 with byte shuffle, Fletcher-32 checksums), so one node's series is read without
touching the other nodes' chunks.

Writes are atomic: data goes to ``<path>.tmp-XXXX`` in the same folder and is renamed onto ``path``
only when the trajectory is complete; a failed or interrupted write leaves no file at ``path`` (and
the previous file, if any, unchanged). Every problem with a file is a one-line ``DatasetError``
naming the file, what is wrong and what to do.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import SoftrnnInputError, bad
from ..files import check_room
from ..geometry.contact import contact_from_record as contact_from_record
from ..geometry.contact import contact_record as contact_record
from ..rod.hub import HUB_CHANNELS as HUB_CHANNELS

SCHEMA_VERSION = 2
"""Version of the file layout of a trajectory without contact (and of a sweep's root without contact
groups). 2 added the optional ``actuation`` dataset (schema 1 files, without it, are read with m = 0
actuation channels)."""

CONTACT_SCHEMA = 3
"""Version of a trajectory with the contact datasets ``contact_forces``, ``contact_torques`` and the
``contact`` attribute (older readers refuse it instead of dropping the contact loads); the newest
schema this softrnn reads."""
# The optional ``scenario_record`` attribute (``softrnn.io.record``) keeps the schema: an older reader
# ignores it and keeps the scenario's text, so nothing is lost; ``record.RECORD_VERSION`` versions it.

TIME_CHUNK = 4096
"""Samples per HDF5 chunk along time (the simulator's chunk length; docs/dataset-format.md#size)."""

COMPRESSION = {"compression": "gzip", "compression_opts": 4, "shuffle": True, "fletcher32": True}
"""HDF5 filters of every chunked dataset: gzip level 4 after a byte shuffle, with checksums."""

POSITION_LIMIT_M = 16.0
"""Largest |coordinate| accepted [m]: float32 rounds a coordinate x by at most 2^-24 |x|, so positions
below 16 m are stored to better than 1e-6 m (1 micrometre)."""

QUATERNION_TOLERANCE = 1e-5
"""Largest accepted | |q| - 1 | of a stored quaternion (float32 rounding itself gives < 2.4e-7)."""

FIELDS = ("positions", "quaternions", "forces", "torques")
_WIDTH = {"positions": 3, "quaternions": 4, "forces": 3, "torques": 3, "contact_forces": 3, "contact_torques": 3}
UNITS = {"time": "s", "positions": "m", "quaternions": "1 (unit, scalar first w x y z, body to world)",
         "forces": "N", "torques": "N m"}
_DESCRIPTION = {
    "time": "sample times, strictly increasing",
    "nodes": "0-based rod node index of each stored column",
    "positions": "node positions, world frame",
    "quaternions": "node orientations as unit quaternions (w, x, y, z), body to world",
    "forces": "applied external forces, world frame",
    "torques": "applied external torques, world frame",
}
CONTACT_FIELDS = ("contact_forces", "contact_torques")
"""The optional per-node datasets (T, N, 3) of the contact loads (schema 3), world frame."""
CONTACT_UNITS = {"contact_forces": "N", "contact_torques": "N m"}
CONTACT_DESCRIPTION = {
    "contact_forces": "contact forces of the obstacles on the nodes (normal and friction), world frame, "
                      "not part of forces",
    "contact_torques": "contact torques on the nodes (the friction's moment about the node), world frame, "
                       "not part of torques",
}
CONTACT = "contact"
"""Name of the group attribute (JSON) describing the obstacles of a trajectory with contact."""

ACTUATION = "actuation"
"""Name of the optional dataset of actuation inputs (T, m)."""

ACTUATION_UNITS = ("1", "%", "N", "N m", "Pa", "kPa", "MPa", "bar", "mbar", "psi", "A", "mA", "V", "mV", "W",
                   "T", "mT", "m", "mm", "rad", "deg", "m/s", "rad/s", "Hz")
"""Units an actuation channel may have (case matters: ``mA`` is not ``MA``); ``1`` for a
dimensionless signal (a duty cycle as a fraction), ``%`` for one in percent."""

ACTUATION_NAME = re.compile(r"^[a-z][a-z0-9_]{0,63}$")
"""An actuation channel's name: a lower-case letter, then letters, digits or ``_`` (at most 64),
e.g. ``tendon_1``, ``p_chamber_2``, ``coil_3``."""

HUB_INPUTS = {"hub_insertion": "hub_force", "hub_rotation": "hub_torque"}
"""Each hub position channel and the channel that drives it when the hub is driven (its position is
then the rod's state, measured, and the driving channel is the input)."""


def hub_inputs(names) -> tuple[str, ...]:
    """The hub channels among the actuation channel ``names`` that are a model's inputs, in order: the
    insertion [m] and rotation [rad] where prescribed, the force [N] and torque [N m] where they drive
    the hub (``HUB_CHANNELS``, written by ``softrnn.rod.hub.HubRecorder``)."""
    names = tuple(names)
    return tuple(a for a in names if a in HUB_CHANNELS and HUB_INPUTS.get(a) not in names)


RESERVED_ATTRS = ("schema_version", "softrnn_version", "units", "rod", "scenario_text", "seed", "dt",
                  "n_nodes_total", "actuation_units", "contact", "scenario_record")
SWEEP_PREFIX = "traj-"
_REQUIRED_ATTRS = ("softrnn_schema", "softrnn_version", "dt", "rod", "scenario", "units", "n_nodes_total", "attrs")


class DatasetError(SoftrnnInputError):
    """A dataset file (or data written to one) that cannot be used; the message is one line:
    ``<path>: what is wrong; what to do``."""


def actuation_units(value, argument: str = "actuation_units") -> dict[str, str]:
    """A checked copy of an actuation channel mapping {name: unit} (column order = key order);
    None gives {} (no actuation). Names must match ``ACTUATION_NAME``, units be in
    ``ACTUATION_UNITS``; a problem is a one-line ``SoftrnnInputError`` naming the channel."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise bad(argument, _short(value), "a dict {channel name: unit}, e.g. {'tendon_1': 'N'}, or None")
    out = {}
    for name, unit in value.items():
        if not isinstance(name, str) or not ACTUATION_NAME.match(name):
            raise bad(argument, _short(value), f"channel names of lower-case letters, digits and '_' starting "
                                               f"with a letter (e.g. 'tendon_1'); {name!r} is not one")
        if not isinstance(unit, str) or unit not in ACTUATION_UNITS:
            raise bad(argument, _short(value), f"a known unit for channel {name!r} (got {unit!r}): one of "
                                               f"{', '.join(ACTUATION_UNITS)}")
        out[name] = unit
    return out


def _group_name(group: str) -> str:
    if not isinstance(group, str) or not group.strip("/") or "/" in group.strip("/") or group.startswith("/."):
        raise bad("group", group, "a group name such as 'traj-00000' (see list_groups)")
    return group.strip("/")


def _to_float32(arr: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        return np.asarray(arr, dtype=np.float32)


def _node_list(nodes) -> str:
    nodes = [int(a) for a in nodes]
    if nodes and nodes == list(range(nodes[0], nodes[-1] + 1)) and len(nodes) > 3:
        return f"{nodes[0]}..{nodes[-1]}"
    if len(nodes) > 12:
        return ", ".join(map(str, nodes[:10])) + f", ... ({len(nodes)} nodes)"
    return ", ".join(map(str, nodes))


def _short(value):
    """``value`` itself, or a shortened text of it when its repr is long (for error messages)."""
    text = repr(value.tolist() if isinstance(value, np.ndarray) else value)
    return value if len(text) <= 80 else _Text(text[:70] + " ...")


class _Text(str):
    def __repr__(self):
        return str(self)


COMPRESSED_FRACTION = 0.1
"""The smallest fraction of its uncompressed size that a trajectory's compressed file reaches (a
bound well below what was measured: 0.3 to 0.45 for the tendon arms): the disk must hold at least
this much (``trajectory_bytes``)."""


def trajectory_bytes(n_samples: int, n_nodes: int, n_actuation: int = 0, contact: bool = False) -> int:
    """Uncompressed bytes of a trajectory file's arrays: ``n_samples`` times (8 bytes), and per
    sample and node the float32 fields (13 values, 6 more with ``contact``), ``n_actuation``
    float32 channels per sample."""
    per_node = sum(_WIDTH[name] for name in FIELDS) + (6 if contact else 0)
    return int(n_samples) * (8 + 4 * (int(n_nodes) * per_node + int(n_actuation)))


def check_trajectory_room(path, n_samples: int, n_nodes: int, n_actuation: int = 0, contact: bool = False,
                          count: int = 1) -> None:
    """Refuse up front (``files.check_room``) ``count`` trajectory files that would not fit the disk
    of ``path`` even compressed to ``COMPRESSED_FRACTION`` of ``trajectory_bytes``."""
    raw = count * trajectory_bytes(n_samples, n_nodes, n_actuation, contact)
    files = f"{count} trajectories" if count > 1 else "the trajectory"
    check_room(path, COMPRESSED_FRACTION * raw,
               f"{files} of {n_samples} samples of {n_nodes} nodes ({raw / 2**30:.3g} GiB uncompressed)",
               "save fewer samples or nodes (a coarser --dt, --samples), or choose an output on another disk",
               least=True)
