"""Obstacles in the rod animation: the geometry helpers (plane patch, sphere, cylinder segment, vessel
wall at its radius from the centreline, 2-D wall lines), every obstacle kind animated in every view,
the obstacles and contact forces read from a dataset file, through the library and the CLI, and a
mesh vessel drawn as its outline and centreline."""

from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest
from PIL import Image

from softrnn.figures import animation, geometry
from softrnn.geometry import MeshVessel
from softrnn.geometry._marching import tube_tree_surface
from softrnn.io import write_trajectory
from softrnn.io.schema import contact_record
from softrnn.rod import Contact, Cylinder, Plane, Sphere, Vessel

from helpers import run_cli

TUBE = np.array([[0.0, 0.0, 0.0], [0.15, 0.03, 0.01], [0.3, 0.0, 0.04], [0.5, -0.02, 0.0]])
LO, HI = np.array([-0.02, -0.05, -0.03]), np.array([0.52, 0.05, 0.04])


def _obstacles():
    return {"plane": Plane((0.0, 0.0, -0.02), (0.0, 0.3, 1.0)),
            "sphere": Sphere((0.25, 0.0, -0.06), 0.04),
            "cylinder": Cylinder((0.0, 0.0, -0.05), (1.0, 1.0, 0.0), 0.02),
            "vessel": Vessel(TUBE, [0.03, 0.04, 0.03, 0.03])}


def _data(kinds, planar=False, contact_forces=True, n_samples=9, n_nodes=7):
    """A rod swinging along the vessel's centreline (in the xy plane when ``planar``), with a
    contact force on the tip half the time and the obstacles ``kinds`` in its attrs."""
    time = np.linspace(0.0, 0.4, n_samples)
    s = np.linspace(0.0, 0.5, n_nodes)
    pos = np.zeros((n_samples, n_nodes, 3))
    pos[..., 0] = s
    pos[..., 1] = 0.02 * np.sin(2 * np.pi * time)[:, None] * (s / 0.5) ** 2
    if not planar:
        pos[..., 2] = 0.01 * (1 - np.cos(2 * np.pi * time))[:, None] * (s / 0.5) ** 2
    quats = np.zeros((n_samples, n_nodes, 4))
    quats[..., 0] = 1.0
    cf = np.zeros_like(pos)
    cf[time < 0.2, -1] = (0.0, -0.3, 0.2)
    contact = Contact(obstacles=tuple(_obstacles()[k] for k in kinds), friction=0.2)
    return SimpleNamespace(time=time, nodes=np.arange(n_nodes), positions=pos, quaternions=quats,
                           forces=np.zeros_like(pos), torques=np.zeros_like(pos),
                           contact_forces=cf if contact_forces else None,
                           contact_torques=np.zeros_like(pos) if contact_forces else None,
                           attrs={"case": "obstacles", "contact": contact_record(contact)})


# ------------------------------------------------------------------------------------------ geometry


def test_vessel_wall_lies_at_its_radius_from_the_centreline():
    vessel = _obstacles()["vessel"]
    mesh = geometry.tube_mesh(vessel.points, vessel.radii, count=12, max_rings=30)
    assert mesh.shape == (30, 12, 3)
    keep = np.unique(np.round(np.linspace(0, len(vessel.points) - 1, 30)).astype(int))
    centre, radius = vessel.points[keep], vessel.radii[keep]
    np.testing.assert_allclose(np.linalg.norm(mesh - centre[:, None], axis=-1), radius[:, None] * np.ones(12),
                               rtol=1e-12)
    tangent = np.gradient(centre, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    np.testing.assert_allclose(np.einsum("kjc,kc->kj", mesh - centre[:, None], tangent), 0.0, atol=1e-12)
    # the walls of a flat view: at the radius on either side, normal to the projected centreline
    c, left, right = geometry.tube_walls_2d(vessel.points, vessel.radii, "xy", max_points=40)
    assert len(vessel.points) > 40 and c.shape == left.shape == right.shape == (40, 2)
    keep = np.unique(np.round(np.linspace(0, len(vessel.points) - 1, 40)).astype(int))
    for wall in (left, right):
        np.testing.assert_allclose(np.linalg.norm(wall - c, axis=1), vessel.radii[keep], rtol=1e-12)
    np.testing.assert_allclose(c, vessel.points[keep][:, :2])


def test_plane_sphere_and_cylinder_meshes():
    normal = np.array([0.0, 0.3, 1.0]) / np.hypot(0.3, 1.0)
    patch = geometry.plane_patch((0.0, 0.0, -0.02), normal, LO, HI)
    assert patch.shape == (4, 3)
    np.testing.assert_allclose((patch - (0.0, 0.0, -0.02)) @ normal, 0.0, atol=1e-15)
    corners = geometry._box_corners(LO, HI)  # the patch covers the box's shadow on the plane
    _, u, v = geometry._frame(normal)
    for e in (u, v):
        assert (patch @ e).min() <= (corners @ e).min() + 1e-12 and (patch @ e).max() >= (corners @ e).max() - 1e-12
    sphere = geometry.sphere_mesh((0.25, 0.0, -0.06), 0.04, count=10)
    np.testing.assert_allclose(np.linalg.norm(sphere - (0.25, 0.0, -0.06), axis=-1), 0.04, rtol=1e-12)
    axis = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    cyl = geometry.cylinder_mesh((0.0, 0.0, -0.05), axis, 0.02, LO, HI, count=10)
    q = cyl - (0.0, 0.0, -0.05)
    radial = q - (q @ axis)[..., None] * axis
    np.testing.assert_allclose(np.linalg.norm(radial, axis=-1), 0.02, rtol=1e-12)
    t = (corners - (0.0, 0.0, -0.05)) @ axis  # the segment spans the box along the axis
    np.testing.assert_allclose((q @ axis)[:, 0], [t.min(), t.max()], rtol=1e-12)


# ------------------------------------------------------------------------------------------ animation


@pytest.mark.parametrize("view", ["xy", "xz", "yz", "3d"])
@pytest.mark.parametrize("kind", ["plane", "sphere", "cylinder", "vessel"])
def test_every_obstacle_kind_in_every_view(kind, view, tmp_path, monkeypatch):
    seen = []
    real = animation.draw_obstacles

    def spy(ax, obstacles, v, lo, hi):
        seen.append((list(obstacles), v))
        return real(ax, obstacles, v, lo, hi)

    monkeypatch.setattr(animation, "draw_obstacles", spy)
    out = tmp_path / f"{kind}-{view}.gif"
    animation.animate(_data([kind]), out, frames=3, size=(160, 140), view=view)
    with Image.open(out) as im:
        assert im.n_frames == 3 and im.size == (160, 140)
    (obstacles, v), = seen
    assert v == view and [o["kind"] for o in obstacles] == [kind]
    if kind == "vessel":
        points, radii = obstacles[0]["points"], obstacles[0]["radii"]
        assert points.shape[1] == 3 and radii.shape == (len(points),)


def test_drawing_makes_artists_and_contact_arrows(tmp_path):
    data = _data(["plane", "sphere", "cylinder", "vessel"], planar=True)
    scene = animation._Scene(data.time, data.nodes, data.positions, data.forces, 0, 8, np.arange(3), node_col=None,
                             view="auto", trail=False, title="t", size=(200, 200),
                             contact_forces=data.contact_forces,
                             obstacles=animation.obstacles_of(data.attrs["contact"]))
    assert scene.view == "xy" and scene.has_contact and not scene.has_forces
    assert scene.cquiver in scene.dynamic
    scene.update(0)
    assert np.abs(scene.cquiver.V).max() > 0  # the tip's contact force is drawn at t = 0
    labels = [t.get_text() for t in scene.fig.legends[0].get_texts()]
    assert "obstacles" in labels and "contact force: 0.2 N = 0.04 m" in labels
    ax = scene.ax
    drawn = animation.draw_obstacles(ax, animation.obstacles_of(data.attrs["contact"]), "xy", *scene.rod_box)
    assert len(drawn) == 3 + 3  # plane, sphere, cylinder patches; vessel centreline and two walls
    scene3 = animation._Scene(data.time, data.nodes, data.positions, None, 0, 8, np.arange(3), node_col=None,
                              view="3d", trail=False, title="t", size=(200, 200),
                              contact_forces=data.contact_forces, obstacles=())
    scene3.update(0)
    assert scene3.carrows in scene3.dynamic and len(scene3.carrows._segments3d) == 3


def test_no_obstacles_when_asked_or_when_there_are_none(tmp_path, monkeypatch):
    seen = []
    monkeypatch.setattr(animation, "draw_obstacles", lambda *a: seen.append(a) or [])
    data = _data(["sphere"])
    animation.animate(data, tmp_path / "a.gif", frames=2, size=(120, 120), obstacles=False, contact_forces=False)
    data.attrs.pop("contact")
    animation.animate(data, tmp_path / "b.gif", frames=2, size=(120, 120))
    assert seen == []
    given = Contact(obstacles=(_obstacles()["plane"],))  # obstacles given by the caller
    animation.animate(data, tmp_path / "c.gif", frames=2, size=(120, 120), obstacles=given)
    assert [o["kind"] for o in seen[0][1]] == ["plane"]


def test_obstacles_and_contact_forces_from_a_file(tmp_path, monkeypatch, capsys):
    data = _data(["plane", "sphere", "cylinder", "vessel"])
    contact = Contact(obstacles=tuple(_obstacles().values()), friction=0.2)
    write_trajectory(tmp_path / "c.h5", data, dt=0.05, contact=contact)
    seen = []
    real = animation.draw_obstacles
    monkeypatch.setattr(animation, "draw_obstacles", lambda ax, obs, *a: seen.append(obs) or real(ax, obs, *a))
    assert run_cli(["animate", str(tmp_path / "c.h5"), "-o", str(tmp_path / "c.gif"), "--frames", "3",
                    "--size", "160x140", "--quiet"]) == 0
    assert "wrote" in capsys.readouterr().out
    assert [o["kind"] for o in seen[0]] == ["plane", "sphere", "cylinder", "vessel"]
    with Image.open(tmp_path / "c.gif") as im:
        assert im.n_frames == 3
    assert run_cli(["animate", str(tmp_path / "c.h5"), "-o", str(tmp_path / "d.gif"), "--frames", "2",
                    "--no-obstacles", "--no-contact-forces", "--quiet"]) == 0
    assert len(seen) == 1


@pytest.mark.parametrize("view", ["xy", "3d"])
def test_a_mesh_vessel_is_drawn_as_its_outline_and_centreline(view, tmp_path):
    tube = MeshVessel(*tube_tree_surface([(np.array([[0.0, 0, 0], [0.5, 0, 0]]), 0.03)], 0.01))
    data = _data(["plane"])
    data.attrs["contact"] = contact_record(Contact(obstacles=(tube,), friction=0.2))
    out = tmp_path / f"mesh-{view}.gif"
    animation.animate(data, out, frames=2, size=(160, 140), view=view)
    with Image.open(out) as im:
        assert im.n_frames == 2
    obstacles = animation.obstacles_of(data.attrs["contact"])
    assert [o["kind"] for o in obstacles] == ["mesh"] and len(obstacles[0]["branches"]) == 1
    np.testing.assert_allclose(obstacles[0]["branches"][0][:, 1:], 0.0, atol=0.01)   # on the tube's axis
    if view == "xy":
        fig, ax = plt.subplots()
        lines = animation.draw_obstacles(ax, obstacles, "xy", LO, HI)[0]
        ends = np.concatenate(lines.get_segments())
        middle = (ends[:, 0] > 0.05) & (ends[:, 0] < 0.45)
        np.testing.assert_allclose(np.abs(ends[middle, 1]), 0.03, atol=0.002)        # the walls' outline
        plt.close(fig)
