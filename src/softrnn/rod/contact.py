"""Contact between the rod and rigid, fixed obstacles, with Coulomb friction (docs/lgvi.md §2.11).

``Setup(contact=Contact(obstacles=(...), friction=mu))`` puts obstacles in the rod's world. The
obstacles (``Plane``, ``Sphere``, ``Cylinder``, ``Vessel``, ``Bifurcation``, ``MeshVessel``) and the ``Contact``
live in ``softrnn.geometry`` (shared with the data files, the pictures and the learned models) and
are imported here too, so ``softrnn.rod.contact.Plane`` and the rest keep working.

The rod's surface is its centreline offset by the rod radius r (per node, overrides included). Per
node and obstacle, with gap g the signed distance from the node to the obstacle's surface minus r
and n the obstacle's unit normal at the node (pointing to the rod's side):

* normal force  f_n = max(0, -k g - c v_n) along n when g < 0 (penalty spring with damping, no
  adhesion), applied at the node;
* friction      f_t = -mu f_n v_t / max(|v_t|, v_s') at the contact point -r n, with v_t the
  tangential velocity of that point, and its moment (-r n) x f_t on the node.

Both are evaluated from the state at the start of each step, with the staggered velocities (like the
PD tracking force), and join the applied loads in both integrators. This module holds the arrays the
kernels read (``rod.kernels``, ``_contact_loads``): the obstacles packed into columns by their
``kind``, the per-node stiffness and damping, the start's tracked vessel segments and its checks.
"""

import math

import numpy as np

from ..errors import bad
from ..geometry.contact import DEFAULT_PENETRATION as DEFAULT_PENETRATION
from ..geometry.contact import DEFAULT_SLIP_VELOCITY as DEFAULT_SLIP_VELOCITY
from ..geometry.contact import Contact as Contact
from ..geometry.mesh import MeshVessel as MeshVessel
from ..geometry.mesh import load_mesh as load_mesh
from ..geometry.obstacles import OBSTACLES as OBSTACLES
from ..geometry.obstacles import UNION_BLEND as UNION_BLEND
from ..geometry.obstacles import VESSEL_MAX_SEGMENTS as VESSEL_MAX_SEGMENTS
from ..geometry.obstacles import VESSEL_SAGITTA as VESSEL_SAGITTA
from ..geometry.obstacles import Bifurcation as Bifurcation
from ..geometry.obstacles import Cylinder as Cylinder
from ..geometry.obstacles import Plane as Plane
from ..geometry.obstacles import Sphere as Sphere
from ..geometry.obstacles import Vessel as Vessel
from ..geometry.obstacles import closest_segments as closest_segments
from .kernels import BIFURCATION, BRANCH, CYLINDER, MESH, PLANE, SELF, SPHERE, VESSEL

STANDARD_GRAVITY = 9.81
"""Reference acceleration [m/s^2] of the default stiffness when the setup has no constant gravity."""



def self_contact_gap(rod) -> int:
    """The least index gap j - i of two segments i < j of ``rod`` (a ``RodSpec``) that may touch:
    2 + ceil(2 r_max / l), l the segment length, so that neighbouring segments of a straight or
    gently bent rod, whose surfaces overlap near their shared nodes, are never in contact."""
    return 2 + math.ceil(2.0 * float(np.max(rod.node_properties()["radius"])) / rod.segment_length - 1e-12)


def node_parameters(contact: Contact, rod, gravity) -> np.ndarray:
    """Per node (n, 3): rod radius r_a [m], stiffness k_a [N/m], damping c_a [N s/m] of a
    ``Contact`` on the rod ``rod`` (a ``RodSpec``) under ``gravity`` (a setup's constant (3,)
    [m/s^2], or a time function: no constant gravity)."""
    radius = rod.node_properties()["radius"]
    lumped = rod.lumped()
    mass, wl = lumped["mass"], lumped["weight"] * rod.segment_length
    if contact.stiffness is not None:
        k = contact.stiffness * wl
    else:
        a_ref = contact.reference_acceleration
        if a_ref is None:
            g = 0.0 if callable(gravity) else float(np.linalg.norm(gravity))
            a_ref = g if g > 0 else STANDARD_GRAVITY
        k = mass * a_ref / (contact.penetration * radius)
    c = 2.0 * np.sqrt(k * mass) if contact.damping is None else contact.damping * wl
    return np.ascontiguousarray(np.stack([radius, k, c], axis=1))


_GEOM = {"plane": lambda ob: (PLANE, (*ob.point, *ob.normal, 0.0)),
         "sphere": lambda ob: (SPHERE, (*ob.center, 0.0, 0.0, 0.0, ob.radius)),
         "cylinder": lambda ob: (CYLINDER, (*ob.point, *ob.axis, ob.radius))}
"""The kernel kind and geom row (7,) of each solid obstacle, by its record's ``kind``."""


def _columns(contact: Contact) -> list:
    """The kernels' obstacle columns: (obstacle index, kernel kind, vessel, mesh or None) per column,
    by the obstacle's ``kind``; a bifurcation as a BIFURCATION column (its left vessel) and a BRANCH
    column (its right one)."""
    columns = []
    for j, ob in enumerate(contact.obstacles):
        if ob.kind == "bifurcation":
            columns += [(j, BIFURCATION, ob.vessels[0]), (j, BRANCH, ob.vessels[1])]
        else:
            columns.append((j, VESSEL, ob) if ob.kind == "vessel" else (j, MESH, ob) if ob.kind == "mesh"
                           else (j, None, None))
    return columns


def mesh_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    """A ``MeshVessel``'s arrays as the kernels read them (``kernels.StepInputs``): integers (I,)
    int64 (V, F, the seed grid's shape, faces, neighbours, ring offsets, ring faces, seed faces) and
    values (M,) (vertices [m], unit face normals, vertex pseudonormals), each flattened row-major."""
    index = np.concatenate([[len(mesh.vertices), len(mesh.faces)], mesh.grid_shape, mesh.faces.reshape(-1),
                            mesh.neighbours.reshape(-1), mesh.ring_offsets, mesh.ring, mesh.grid_faces])
    values = np.concatenate([mesh.vertices.reshape(-1), mesh.face_normals.reshape(-1),
                             mesh.vertex_normals.reshape(-1)])
    return index.astype(np.int64), values


def kernel_arrays(contact: Contact, rod, gravity) -> dict:
    """The static contact fields of ``kernels.StepInputs`` (contact_kind, contact_geom,
    contact_range, contact_friction, contact_points, contact_radii, contact_mesh_index,
    contact_mesh_values, contact_node) for a ``Contact`` on the rod ``rod`` (a ``RodSpec``) under
    ``gravity`` (see ``node_parameters``): one column per obstacle, a ``Bifurcation`` one per
    vessel, a ``MeshVessel``'s arrays by ``mesh_arrays``, and a last SELF column with
    ``self_contact`` (its geom[0]: ``self_contact_gap``)."""
    columns = _columns(contact)
    o = len(columns)
    kind = np.zeros(o, dtype=np.int64)
    geom = np.zeros((o, 7))
    rng = np.zeros((o, 2), dtype=np.int64)
    points, radii, start = [], [], 0
    index, values, sizes = [], [], [0, 0]
    for c, (j, kd, vessel) in enumerate(columns):
        if vessel is None:
            kind[c], geom[c] = _GEOM[contact.obstacles[j].kind](contact.obstacles[j])
        elif kd == MESH:
            kind[c], rng[c] = MESH, sizes
            geom[c, :4] = (*vessel.grid_origin, vessel.grid_cell)
            ints, floats = mesh_arrays(vessel)
            index.append(ints)
            values.append(floats)
            sizes = [sizes[0] + len(ints), sizes[1] + len(floats)]
        else:
            kind[c], rng[c] = kd, (start, len(vessel.points))
            points.append(vessel.points)
            radii.append(vessel.radii)
            start += len(vessel.points)
    friction = np.array([[contact.friction_of(contact.obstacles[j]), contact.slip_velocity] for j, *_ in columns]
                        ).reshape(o, 2)
    if contact.self_contact:                 # the last column: between the rod's own segments
        kind = np.append(kind, SELF)
        geom = np.vstack([geom, [[self_contact_gap(rod), 0, 0, 0, 0, 0, 0]]])
        rng = np.vstack([rng, np.zeros((1, 2), dtype=np.int64)])
        friction = np.vstack([friction, [[0.0, contact.slip_velocity]]])
    return dict(contact_kind=kind, contact_geom=geom, contact_range=rng, contact_friction=friction,
                contact_points=np.ascontiguousarray(np.concatenate(points) if points else np.zeros((0, 3))),
                contact_radii=np.ascontiguousarray(np.concatenate(radii) if radii else np.zeros(0)),
                contact_mesh_index=np.concatenate(index) if index else np.zeros(0, dtype=np.int64),
                contact_mesh_values=np.concatenate(values) if values else np.zeros(0),
                contact_node=node_parameters(contact, rod, gravity))


def initial_segments(contact: Contact, positions: np.ndarray) -> np.ndarray:
    """The tracked vessel segments (n, o) int64 at node positions (n, 3) [m], one column per
    kernel column (``kernel_arrays``): the closest segment of each vessel, a bifurcation's included,
    by brute force, the closest face of a mesh (0 in the columns of other obstacles)."""
    columns = _columns(contact)
    seg = np.zeros((len(positions), len(columns) + int(contact.self_contact)), dtype=np.int64)
    for c, (_, kd, vessel) in enumerate(columns):
        if kd == MESH:
            seg[:, c] = vessel.closest_faces(positions)
        elif vessel is not None:
            seg[:, c] = closest_segments(vessel.points, positions)[0]
    return seg


def check_initial(contact: Contact, positions: np.ndarray, radius: np.ndarray) -> None:
    """Refuse rod radii (n,) [m] wider than a vessel, and node positions (n, 3) [m] that start deeper
    in an obstacle than the rod's radius, with a one-line error naming the node and obstacle."""
    for j, ob in enumerate(contact.obstacles):
        for vessel in ob.vessels if ob.kind == "bifurcation" else (ob,) if ob.kind == "vessel" else ():
            if np.max(radius) >= np.min(vessel.radii):
                raise bad(f"contact.obstacles[{j}].radius", float(np.min(vessel.radii)),
                          f"a vessel wider than the rod (rod radius up to {np.max(radius):.4g} m)")
    gaps = contact.gaps(positions, radius)
    deep = gaps < -radius[:, None]
    if np.any(deep):
        a, j = np.argwhere(deep)[0]
        name = type(contact.obstacles[j]).__name__
        raise bad("initial", f"node {a} {-gaps[a, j]:.3g} m inside obstacle {j} ({name})",
                  "an initial shape on the rod's side of every obstacle (at most the rod radius inside)")


def step_limit(nodes: np.ndarray, mass: np.ndarray, omega: float = 0.0) -> float:
    """Largest stable step [s] of the explicit contact spring and damper of every node (before a
    safety factor): the scalar leapfrog with explicit damping is stable for h^2 w^2 + 2 h g < 4,
    with w^2 = omega^2 + max k_a/m_a (the node's elastic frequency omega [rad/s] plus the spring)
    and g = max c_a/m_a; ``nodes`` (n, 3) from ``node_parameters``, ``mass`` (n,) [kg]."""
    w2 = omega**2 + float(np.max(nodes[:, 1] / mass))
    g = float(np.max(nodes[:, 2] / mass))
    return (-g + math.sqrt(g * g + 4.0 * w2)) / w2
