"""Contact of the rod with rigid, fixed obstacles: the ``Contact`` (its obstacles and the contact law's
parameters, docs/lgvi.md §2.11) and its record, the ``contact`` attribute of a data file
(``contact_record``, ``contact_from_record``; docs/dataset-format.md)."""

from dataclasses import dataclass

import numpy as np

from ..errors import bad, finite, nonnegative, positive
from .obstacles import Obstacle, _short

DEFAULT_PENETRATION = 0.005
"""Default penetration at the reference load, as a fraction of the rod radius: half the 1 % the
contact is designed for, a margin of 2 for the share of the rod's weight that bending moves onto
one node."""

DEFAULT_SLIP_VELOCITY = 1e-4
"""Default slip velocity v_s [m/s] of the regularised Coulomb friction."""


@dataclass(frozen=True, kw_only=True, eq=False)
class Contact:
    """Contact of the rod with rigid, fixed obstacles (docs/lgvi.md §2.11).

    Attributes
    ----------
    obstacles : tuple
        ``Plane``, ``Sphere``, ``Cylinder``, ``Vessel``, ``Bifurcation`` and ``MeshVessel`` entries
        (one obstacle alone is accepted)
    friction : float
        Coulomb friction coefficient mu [-] of the obstacles that set none (0: frictionless)
    slip_velocity : float
        v_s [m/s] > 0: friction grows linearly with the slip velocity below it (regularised
        Coulomb); the kernels raise it, where needed, to h mu f_n / m_eff for a stable step
    stiffness : float or None
        penalty stiffness per length of rod [N/m^2] (node a gets k w_a l); None: per node
        k_a = m_a a_ref / (penetration r_a), the node's weight under a_ref penetrates by
        ``penetration`` times its radius
    damping : float or None
        normal damping per length of rod [N s/m^2] (node a gets c w_a l); None: critical,
        c_a = 2 sqrt(k_a m_a)
    penetration : float
        the default stiffness' penetration at the reference load, a fraction of the rod radius in
        (0, 1)
    reference_acceleration : float or None
        a_ref [m/s^2] > 0 of the default stiffness; None: |g| of the setup's constant gravity, or
        ``STANDARD_GRAVITY`` without one
    self_contact : bool
        also contact between the rod's own segments (frictionless, with the same stiffness and
        damping per node, in series; ``self_contact_gap``); the obstacles may then be empty
    implicit : bool
        with the implicit integrator, take the normal spring and damper of every touching node into
        its linear solve (linearly implicit contact, docs/guide/simulator.md "Stiff rods"): the contact
        stiffness no longer bounds the step; ignored by the explicit integrator
    """

    obstacles: tuple = ()
    friction: float = 0.0
    slip_velocity: float = DEFAULT_SLIP_VELOCITY
    stiffness: float | None = None
    damping: float | None = None
    penetration: float = DEFAULT_PENETRATION
    reference_acceleration: float | None = None
    self_contact: bool = False
    implicit: bool = False

    def __post_init__(self):
        obstacles = (self.obstacles,) if isinstance(self.obstacles, Obstacle) else self.obstacles
        try:
            obstacles = tuple(obstacles)
        except TypeError:
            raise bad("contact.obstacles", self.obstacles,
                      "a tuple of Plane, Sphere, Cylinder, Vessel, Bifurcation or MeshVessel") from None
        if not isinstance(self.self_contact, bool):
            raise bad("contact.self_contact", self.self_contact, "true or false")
        if not isinstance(self.implicit, bool):
            raise bad("contact.implicit", self.implicit, "true or false")
        if not (obstacles or self.self_contact) or not all(isinstance(o, Obstacle) and o.kind for o in obstacles):
            raise bad("contact.obstacles", self.obstacles,
                      "one or more Plane, Sphere, Cylinder, Vessel, Bifurcation or MeshVessel entries (or none, with "
                      "self_contact = true)")
        object.__setattr__(self, "obstacles", obstacles)
        object.__setattr__(self, "friction", nonnegative("contact.friction", self.friction))
        object.__setattr__(self, "slip_velocity", positive("contact.slip_velocity", self.slip_velocity, "m/s"))
        for name, unit in (("stiffness", "N/m^2"), ("damping", "N s/m^2")):
            if getattr(self, name) is not None:
                check = positive if name == "stiffness" else nonnegative
                object.__setattr__(self, name, check(f"contact.{name}", getattr(self, name), unit))
        p = finite("contact.penetration", self.penetration)
        if not 0 < p < 1:
            raise bad("contact.penetration", self.penetration, "a fraction of the rod radius in (0, 1), e.g. 0.005")
        if self.reference_acceleration is not None:
            positive("contact.reference_acceleration", self.reference_acceleration, "m/s^2")

    def to_record(self) -> dict:
        """The record of this contact (``contact_record``)."""
        return contact_record(self)

    @staticmethod
    def from_record(record) -> "Contact":
        """The ``Contact`` of a record (``contact_from_record``)."""
        return contact_from_record(record)

    def friction_of(self, obstacle) -> float:
        """The friction coefficient [-] of one of the obstacles (its own, or the Contact's)."""
        return self.friction if obstacle.friction is None else obstacle.friction

    def gaps(self, positions: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """Gaps (n, o) [m] of the rod's surface to each obstacle at node positions (n, 3) [m] with
        rod radii (n,) [m] (NumPy, brute force; inf where no contact is possible; o = 0 without
        obstacles)."""
        x = np.asarray(positions, dtype=float)
        return np.stack([o.gap(x, radius)[0] for o in self.obstacles] or [np.zeros((0, len(x)))], axis=-1
                        ).reshape(len(x), len(self.obstacles))


CONTACT_KEYS = ("friction", "slip_velocity", "stiffness", "damping", "penetration", "reference_acceleration")
"""The ``Contact``'s parameters in its record, besides its obstacles and ``self_contact``."""


def contact_record(contact) -> dict | None:
    """The ``contact`` attribute (a JSON-ready dict) of a ``Contact`` (docs/dataset-format.md).

    Parameters
    ----------
    contact : Contact, dict or None
        the setup's contact (``Setup.contact``), or a record of this form (checked by rebuilding
        the Contact); None gives None

    Returns
    -------
    dict or None
        the contact law's parameters (``CONTACT_KEYS``: ``friction`` [-], ``slip_velocity`` [m/s],
        ``stiffness`` [N/m^2], ``damping`` [N s/m^2], ``penetration`` [-],
        ``reference_acceleration`` [m/s^2], None for a default rule), ``obstacles`` (each one's
        ``Obstacle.to_record``, with the friction that applies to it), ``self_contact`` and
        ``implicit`` (true, only where set).
    """
    if contact is None:
        return None
    if isinstance(contact, dict):
        contact = contact_from_record(contact)
    if not isinstance(contact, Contact):
        raise bad("contact", _short(contact), "a softrnn.rod.Contact (Setup.contact), a stored contact record, or None")
    record = {key: getattr(contact, key) for key in CONTACT_KEYS}
    record = {k: None if v is None else float(v) for k, v in record.items()}
    record["obstacles"] = [ob.to_record(contact.friction_of(ob)) for ob in contact.obstacles]
    if contact.self_contact:          # only where set: records without it read as before
        record["self_contact"] = True
    if contact.implicit:
        record["implicit"] = True
    return record


def contact_from_record(record) -> Contact:
    """The ``softrnn.rod.Contact`` of a stored ``contact`` record (see ``contact_record``); a
    malformed one is a one-line ``SoftrnnInputError``."""
    if not isinstance(record, dict) or not isinstance(record.get("obstacles"), list):
        raise bad("contact", _short(record), "a dict with 'obstacles' (a list) and the contact parameters "
                                             "(see softrnn.geometry.contact.contact_record)")
    obstacles = [Obstacle.from_record(entry, f"contact.obstacles[{j}]") for j, entry in enumerate(record["obstacles"])]
    options = {k: record[k] for k in CONTACT_KEYS if record.get(k) is not None}
    if "self_contact" in record:
        options["self_contact"] = record["self_contact"]
    if "implicit" in record:
        options["implicit"] = record["implicit"]
    try:
        return Contact(obstacles=tuple(obstacles), **options)
    except TypeError as err:
        raise bad("contact", _short(record), f"a valid contact record ({err})") from None
