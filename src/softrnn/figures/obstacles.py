"""The obstacles of a contact as drawn: ``obstacles_of`` turns a ``softrnn.rod.Contact`` or its
stored record into one dict per obstacle, ``draw_obstacles`` draws them on a flat or 3-D view.

A plane is a translucent rectangle around the rod's extent, a sphere a translucent surface (a disc
in a flat view), a cylinder a surface segment over the rod's extent (its shadow in a flat view), a
vessel its centreline and a translucent tube (two wall lines in a flat view), a mesh vessel its
centreline branches and its surface (its outline, the edges where it turns away, in a flat view).
An obstacle with ``vessels`` (a tuple of vessels) is drawn as each of them.
"""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.patches import Circle, Polygon
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from scipy.spatial import ConvexHull, QhullError

from ..errors import bad
from ..geometry.contact import contact_from_record
from .geometry import _PLANES, cylinder_mesh, plane_patch, sphere_mesh, tube_mesh, tube_walls_2d

OBSTACLE_COLOR = "#8c564b"
"""The obstacles' colour (the legend's patch too)."""
OBSTACLE_ALPHA = 0.22
"""The obstacles' opacity."""


def obstacles_of(contact) -> list[dict]:
    """The obstacles to draw of a contact: a ``softrnn.rod.Contact`` (or an object with its
    ``obstacles`` and ``friction``), a stored record (a dataset's ``attrs['contact']``,
    ``softrnn.io.schema.contact_record``) or None (none). One dict per obstacle as in the record
    (``kind``, geometry [m] and ``friction``: ``Obstacle.to_record``); a vessel's also has ``points``
    (P, 3) and ``radii`` (P,) [m], its dense centreline (``softrnn.geometry.Vessel.points``). A
    bifurcation (an obstacle with ``vessels``) is drawn as each of its vessels."""
    if contact is None:
        return []
    built = contact_from_record(contact) if isinstance(contact, dict) else contact
    obstacles = getattr(built, "obstacles", None)
    if obstacles is None:
        raise bad("contact", type(built).__name__, "a softrnn.rod.Contact, a stored contact record, or None")
    default = float(getattr(built, "friction", 0.0) or 0.0)
    return [entry for ob in obstacles for entry in _obstacle_entries(ob, default)]


_DRAWN = ("plane", "sphere", "cylinder", "vessel", "mesh")
"""The obstacle kinds drawn as they are (``softrnn.geometry.obstacles``); a bifurcation as its vessels."""


def _obstacle_entries(ob, friction: float) -> list[dict]:
    """The drawn entries of one obstacle (see ``obstacles_of``): its record (``kind``), a vessel's with
    its dense polyline; an obstacle made of vessels (``vessels``, a bifurcation) as its vessels'."""
    kind = getattr(ob, "kind", None)
    own = getattr(ob, "friction", None)
    mu = friction if own is None else float(own)
    if getattr(ob, "vessels", None) is not None:       # a union of vessels (a Bifurcation)
        return [e for v in ob.vessels for e in _obstacle_entries(v, mu)]
    if kind not in _DRAWN:
        raise bad("contact.obstacles", type(ob).__name__, "Plane, Sphere, Cylinder or Vessel obstacles, or ones with "
                                                          "vessels (a tuple of Vessel)")
    entry = ob.to_record(mu)
    if kind == "vessel":
        entry.update(points=np.asarray(ob.points), radii=np.asarray(ob.radii))
    if kind == "mesh":
        entry.update(vertices=np.asarray(ob.vertices), faces=np.asarray(ob.faces), neighbours=ob.neighbours,
                     normals=ob.face_normals, branches=ob.centreline.branches)
    return [entry]


def draw_obstacles(ax, obstacles, view: str, lo, hi) -> list:
    """Draw ``obstacles`` (``obstacles_of``) on the axes ``ax`` of the view ``view`` ('xy', 'xz',
    'yz' or '3d') around the rod's extent, the box [lo, hi] (3,) [m]; returns the artists made.

    Planes are rectangles over the box, cylinders segments over its span on their axis, spheres
    whole, vessels their centreline and wall; all translucent, under the rod. In 3-D they are
    clipped to the axes' limits."""
    artists = []
    for ob in obstacles:
        kind = ob["kind"]
        if view == "3d":
            artists += _draw_3d(ax, ob, kind, lo, hi)
            continue
        a, b = _PLANES[view]
        if kind == "mesh":
            artists += _draw_mesh_2d(ax, ob, a, b)
            continue
        if kind == "vessel":
            c, left, right = tube_walls_2d(ob["points"], ob["radii"], view)
            artists += ax.plot(c[:, 0], c[:, 1], color=OBSTACLE_COLOR, lw=0.8, ls="-.", zorder=0.5)
            artists += ax.plot(left[:, 0], left[:, 1], right[:, 0], right[:, 1], color=OBSTACLE_COLOR, lw=1.2,
                               zorder=0.5)
            continue
        if kind == "sphere":
            patch = Circle((ob["center"][a], ob["center"][b]), ob["radius"])
        else:
            if kind == "plane":
                pts = plane_patch(ob["point"], ob["normal"], lo, hi)
            else:
                pts = cylinder_mesh(ob["point"], ob["axis"], ob["radius"], lo, hi).reshape(-1, 3)
            patch = Polygon(_outline(pts[:, [a, b]]), closed=True)
        patch.set(facecolor=OBSTACLE_COLOR, alpha=OBSTACLE_ALPHA, edgecolor=OBSTACLE_COLOR, lw=1.0, zorder=0.5)
        artists.append(ax.add_patch(patch))
    return artists


def _outline(points: np.ndarray) -> np.ndarray:
    """The convex outline (k, 2) of projected points (m, 2) (a flat one: its two ends)."""
    try:
        return points[ConvexHull(points).vertices]
    except (QhullError, ValueError):  # collinear: a plane seen edge-on
        d = points - points.mean(0)
        _, _, vt = np.linalg.svd(d, full_matrices=False)
        t = d @ vt[0]
        return points[[int(np.argmin(t)), int(np.argmax(t))]]


def _draw_mesh_2d(ax, ob: dict, a: int, b: int) -> list:
    """A mesh vessel in the flat view of axes a, b: its outline (the edges between a face turned
    toward the viewer and one turned away) and its centreline branches (dash-dot)."""
    view = np.zeros(3)
    view[3 - a - b] = 1.0
    facing = ob["normals"] @ view > 0
    f, k = np.nonzero(facing[:, None] != facing[ob["neighbours"]])
    keep = f < ob["neighbours"][f, k]
    f, k = f[keep], k[keep]
    ends = ob["vertices"][np.stack([ob["faces"][f, k], ob["faces"][f, (k + 1) % 3]], axis=1)][:, :, [a, b]]
    lines = LineCollection(ends, colors=OBSTACLE_COLOR, linewidths=1.0, zorder=0.5)
    out = [ax.add_collection(lines, autolim=True)]
    for line in ob["branches"]:
        out += ax.plot(line[:, a], line[:, b], color=OBSTACLE_COLOR, lw=0.8, ls="-.", zorder=0.5)
    return out


def _draw_3d(ax, ob: dict, kind: str, lo, hi) -> list:
    """One obstacle on 3-D axes (see ``draw_obstacles``)."""
    style = dict(color=OBSTACLE_COLOR, alpha=OBSTACLE_ALPHA, linewidth=0, shade=False, axlim_clip=True)
    if kind == "mesh":
        poly = Poly3DCollection(ob["vertices"][ob["faces"]], facecolor=OBSTACLE_COLOR, alpha=OBSTACLE_ALPHA / 2,
                                linewidth=0)
        ax.add_collection3d(poly, autolim=False, axlim_clip=True)
        return [poly] + [ax.plot(c[:, 0], c[:, 1], c[:, 2], color=OBSTACLE_COLOR, lw=0.8, ls="-.",
                                 axlim_clip=True)[0] for c in ob["branches"]]
    if kind == "plane":
        poly = Poly3DCollection([plane_patch(ob["point"], ob["normal"], lo, hi)], facecolor=OBSTACLE_COLOR,
                                alpha=OBSTACLE_ALPHA, edgecolor=OBSTACLE_COLOR)
        ax.add_collection3d(poly, autolim=False, axlim_clip=True)
        return [poly]
    if kind == "sphere":
        mesh = sphere_mesh(ob["center"], ob["radius"])
    elif kind == "cylinder":
        mesh = cylinder_mesh(ob["point"], ob["axis"], ob["radius"], lo, hi)
    else:
        mesh = tube_mesh(ob["points"], ob["radii"])
    out = [ax.plot_surface(mesh[..., 0], mesh[..., 1], mesh[..., 2], **style)]
    if kind == "vessel":
        c = ob["points"]
        out += ax.plot(c[:, 0], c[:, 1], c[:, 2], color=OBSTACLE_COLOR, lw=0.8, ls="-.", axlim_clip=True)
    return out
