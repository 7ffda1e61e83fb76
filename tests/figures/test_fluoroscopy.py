"""The fluoroscopy look of the rod animation (softrnn.figures.fluoroscopy): the contrast-filled lumen
darker than the X-ray field, the radiopaque wire darker than the lumen, the same bytes on every run,
the style picked for vessel data, and obstacles with ``vessels`` drawn as each of their vessels
(given directly or read back from a dataset's contact record)."""

from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from softrnn.errors import SoftrnnInputError
from softrnn.figures import _movie, animation, fluoroscopy
from softrnn.figures import obstacles as figure_obstacles
from softrnn.io.schema import contact_record
from softrnn.rod import Contact, Sphere, Vessel
from softrnn.rod import contact as contact_module

RADIUS = 0.003  # m, the vessel's
WIRE = 0.00045  # m, the rod's radius


def _data(n_samples=4, n_nodes=11, contact=None):
    """A rod along a straight vessel on the x axis (radius 3 mm) in the xy plane, its tip at x = 0,
    resting 1 mm below the centreline, moving 1 mm along x over the record."""
    time = np.linspace(0.0, 0.3, n_samples)
    pos = np.zeros((n_samples, n_nodes, 3))
    pos[..., 0] = np.linspace(-0.1, 0.0, n_nodes)[None] + 0.001 * (time / time[-1])[:, None]
    pos[..., 1] = -0.001
    contact = contact or Contact(obstacles=(Vessel([[-0.2, 0.0, 0.0], [0.2, 0.0, 0.0]], RADIUS),), friction=0.1)
    return SimpleNamespace(time=time, nodes=np.arange(n_nodes), positions=pos, forces=np.zeros_like(pos),
                           attrs={"case": "wire", "rod": {"radius": WIRE}, "contact": contact_record(contact)})


def _frame(data, size=(320, 280)):
    """The first frame (H, W) grey and its scene."""
    scene = fluoroscopy.FluoroScene(data.time, data.positions, 0, len(data.time) - 1, np.arange(len(data.time)),
                                    view="auto", title="wire", size=size,
                                    obstacles=animation.obstacles_of(data.attrs["contact"]), rod_radius=WIRE)
    frames = []
    _movie.render_frames(scene, np.array([0]), lambda rgba: frames.append(np.array(rgba)))
    rgb = frames[0][..., :3].astype(int)
    assert np.all(rgb[..., 0] == rgb[..., 1]) and np.all(rgb[..., 1] == rgb[..., 2])  # greys only
    return rgb[..., 0], scene


def _pixel(scene, image, x, y) -> int:
    """The grey at the point (x, y) [m]."""
    px, py = scene.ax.transData.transform((x, y))
    return int(image[image.shape[0] - 1 - int(py), int(px)])


def test_lumen_is_darker_than_the_field_and_the_wire_darker_than_the_lumen():
    image, scene = _frame(_data())
    assert scene.view == "xy"
    x0, x1 = scene.ax.get_xlim()
    y0, y1 = scene.ax.get_ylim()
    assert x0 < -0.012 and x1 > 0.012 and y1 - y0 < 0.06  # framed around the tip, not the whole 0.4 m
    for x in (-0.006, 0.006):  # the field well outside the vessel, on both sides
        lumen = _pixel(scene, image, x, 0.0)
        for y in (0.009, -0.009):
            assert _pixel(scene, image, x, y) > lumen + 40
    # the wire (at y = -1 mm) against the lumen at the same place beyond its tip; the tip is darkest
    lumen_beside = _pixel(scene, image, 0.006, -0.001)
    assert _pixel(scene, image, -0.006, -0.001) < lumen_beside - 40
    # the wire at its true diameter in pixels, the radiopaque tip thicker
    wire_pixels = scene.wire.get_linewidth() * 100 / 72
    np.testing.assert_allclose(wire_pixels, 2 * WIRE / ((x1 - x0) / 320), rtol=1e-9)
    assert scene.tip.get_linewidth() > scene.wire.get_linewidth()
    # centre darker than near the wall: the X-rays cross more contrast there
    assert _pixel(scene, image, 0.006, 0.0) < _pixel(scene, image, 0.006, 0.0027)


def test_the_same_picture_every_run(tmp_path):
    data = _data()
    for name in ("a.gif", "b.gif"):
        animation.animate(data, tmp_path / name, frames=3, size=(200, 160), style="fluoroscopy")
    assert (tmp_path / "a.gif").read_bytes() == (tmp_path / "b.gif").read_bytes()
    with Image.open(tmp_path / "a.gif") as im:
        assert im.n_frames == 3 and im.size == (200, 160)
    np.testing.assert_array_equal(fluoroscopy.xray_background(50, 40, seed=3), fluoroscopy.xray_background(50, 40, 3))
    assert not np.array_equal(fluoroscopy.xray_background(50, 40, 3), fluoroscopy.xray_background(50, 40, 4))


def test_style_auto_picks_fluoroscopy_for_flat_vessel_data():
    data = _data()
    drawn = animation.obstacles_of(data.attrs["contact"])
    assert animation.pick_style("auto", drawn, "auto", data.positions) == "fluoroscopy"
    assert animation.pick_style("auto", drawn, "3d", data.positions) == "plain"
    assert animation.pick_style("auto", [], "auto", data.positions) == "plain"
    assert animation.pick_style("plain", drawn, "xy", data.positions) == "plain"
    spatial = data.positions.copy()
    spatial[..., 2] = np.linspace(0.0, 0.05, spatial.shape[1])
    spatial[1:, :, 1] += 0.02
    assert animation.pick_style("auto", drawn, "auto", spatial) == "plain"
    assert fluoroscopy.fluoroscopy_view("auto", spatial) in ("xy", "xz", "yz")
    with pytest.raises(SoftrnnInputError, match="style"):
        animation.pick_style("xray", drawn, "xy", data.positions)
    with pytest.raises(SoftrnnInputError, match="view='3d'"):
        animation.animate(data, "never.gif", frames=2, view="3d", style="fluoroscopy")


class _Branching:
    """A stand-in for an obstacle made of several vessels (e.g. a bifurcation)."""

    def __init__(self, vessels, friction=None):
        self.vessels, self.friction = tuple(vessels), friction


def _branches():
    trunk = Vessel([[-0.2, 0.0, 0.0], [0.0, 0.0, 0.0]], RADIUS)
    up = Vessel([[0.0, 0.0, 0.0], [0.05, 0.03, 0.0], [0.1, 0.05, 0.0]], 0.002)
    down = Vessel([[0.0, 0.0, 0.0], [0.05, -0.03, 0.0], [0.1, -0.05, 0.0]], 0.002, friction=0.3)
    return _Branching((trunk, up, down), friction=0.05)


def test_an_obstacle_with_vessels_is_drawn_as_each_vessel(tmp_path, monkeypatch):
    contact = SimpleNamespace(obstacles=(_branches(), Sphere((0.0, 0.0, 0.01), 0.002)), friction=0.1)
    drawn = animation.obstacles_of(contact)
    assert [o["kind"] for o in drawn] == ["vessel", "vessel", "vessel", "sphere"]
    assert [o["friction"] for o in drawn] == [0.05, 0.05, 0.3, 0.1]
    assert drawn[1]["radii"].max() == 0.002 and drawn[1]["points"].shape[1] == 3
    # the plain style: each vessel's centreline and two walls
    scene = animation._Scene(*(lambda d: (d.time, d.nodes, d.positions, None))(_data()), 0, 3, np.arange(2),
                             node_col=None, view="xy", trail=False, title="t", size=(160, 140))
    assert len(animation.draw_obstacles(scene.ax, drawn[:3], "xy", *scene.rod_box)) == 3 * 3
    # through animate, given directly and as read back from a dataset's contact record
    data = _data()
    for style in ("plain", "fluoroscopy"):
        animation.animate(data, tmp_path / f"{style}.gif", frames=2, size=(160, 140), obstacles=contact, style=style)
    seen = []
    real = fluoroscopy.lumen_depth
    monkeypatch.setattr(fluoroscopy, "lumen_depth", lambda vessels, *a: seen.append(vessels) or real(vessels, *a))
    monkeypatch.setattr(figure_obstacles, "contact_from_record", lambda record: contact)
    data.attrs["contact"] = {"obstacles": [{"kind": "bifurcation"}]}
    animation.animate(data, tmp_path / "record.gif", frames=2, size=(160, 140), style="auto")
    assert [len(v) for v in seen] == [3]
    with pytest.raises(SoftrnnInputError, match="Plane, Sphere, Cylinder or Vessel"):
        animation.obstacles_of(SimpleNamespace(obstacles=(object(),), friction=0.0))


def test_a_branching_vessel_is_one_lumen():
    bifurcation = getattr(contact_module, "Bifurcation", None)
    if bifurcation is None:
        pytest.skip("no Bifurcation obstacle in this tree")
    ob = bifurcation([[-0.1, 0, 0], [0.0, 0, 0]], [[0.04, 0.03, 0], [0.08, 0.05, 0]],
                     [[0.04, -0.03, 0], [0.08, -0.05, 0]], 0.004, left_radius=0.003)
    contact = Contact(obstacles=(ob,), friction=0.1)
    for source in (contact, contact_record(contact)):  # given, and read back from a dataset's record
        assert [o["kind"] for o in animation.obstacles_of(source)] == ["vessel", "vessel"]
    box = (-0.05, 0.05, -0.04, 0.04)
    depth = fluoroscopy.lumen_depth(animation.obstacles_of(contact), "xy", box, 200, 160)
    # the trunk (both vessels') is as dark as a branch (one vessel's): a union, not a sum
    trunk, branch = depth[80, 40], depth[80 - 60, 100 + 80]  # (x, y) = (-0.03, 0) and about (0.04, 0.03)
    assert trunk == pytest.approx(1.0, abs=0.05) and depth.max() <= 1.0
    assert depth[:, 40].sum() == pytest.approx(depth[:, 10].sum())  # the trunk's profile, the same everywhere
    assert branch > 0.3
