"""Contact inside a bifurcating vessel (``softrnn.rod.contact.Bifurcation``, docs/lgvi.md §2.11): the
lumen is the union of the two tubes (trunk + left branch, trunk + right branch). A node inside
either tube feels no wall force, at the junction none either; outside both the nearer wall pushes
it back, in the kernels exactly as in the NumPy reference. A rod pushed through the trunk follows
the branch in line with it and stays inside, with the tracked segment of each tube the brute-force
closest one, in both integrators; a bifurcation with two equal branches is that vessel. Nonsense
geometry is refused in one line, and the record of a dataset gives the same bifurcation back."""

import json
import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io.schema import contact_from_record, contact_record
from softrnn.rod import (
    Bifurcation,
    Clamp,
    Contact,
    Damping,
    RodSpec,
    RunConfig,
    Setup,
    Simulator,
    Vessel,
    straight,
)
from softrnn.rod.contact import closest_segments, kernel_arrays
from softrnn.rod.kernels import BIFURCATION, BRANCH, contact_wrench_into

G = 9.81
R_ROD = 0.002          # rod radius [m]
R_VESSEL = 0.006       # inner radius of trunk and branches [m]
N = 21
LENGTH = 0.2
ANGLE = math.radians(35)   # the side branch's angle to the trunk
JUNCTION = 0.15        # x of the junction [m]


def _rod(n=N, radius=R_ROD):
    return RodSpec(length=LENGTH, radius=radius, youngs_modulus=1e6, density=1000.0, n_nodes=n)


def _y(side=+1, angle=ANGLE, radius=R_VESSEL, branch=0.1):
    """A symmetric Y in the xy-plane: the trunk along x to the junction, the left branch at +angle
    (toward +y), the right one at -angle, each ``branch`` long, as three points."""
    def arm(s):
        return [[JUNCTION + t * branch * math.cos(angle), s * t * branch * math.sin(angle), 0.0] for t in (0.5, 1.0)]
    return Bifurcation([[-0.05, 0.0, 0.0], [JUNCTION, 0.0, 0.0]], arm(side), arm(-side), radius)


def _wrench(setup, positions):
    """The kernels' contact force (n, 3) [N] on nodes at ``positions`` (n, 3) at rest."""
    sim = Simulator(setup)
    n = len(positions)
    st = sim.state
    st.positions[:] = positions
    seg = np.stack([closest_segments(v.points, positions)[0] for ob in setup.contact.obstacles
                    for v in (ob.vessels if isinstance(ob, Bifurcation) else (ob,))], axis=1)
    st.contact_segment[:] = seg
    inputs = sim.inputs.with_contact(sim.inputs.at(np.array([0.0]), 1e-5), st.contact_segment, np.zeros((0, 0, 6)))
    wrench = np.zeros((n, 6))
    contact_wrench_into(1e-5, st.rotations, st.positions, st.velocities, st.angular_velocities, sim.rod, inputs,
                        wrench)
    return wrench[:, :3], sim.inputs.contact["contact_node"][:, 1]


def _probe_setup(bif, n):
    """A setup of n nodes whose positions the probes overwrite (its own shape well inside the trunk)."""
    shape = straight(n, 0.01 * (n - 1), origin=(-0.04, 0.0, 0.0), direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    rod = RodSpec(length=0.01 * (n - 1), radius=R_ROD, youngs_modulus=1e6, density=1000.0, n_nodes=n)
    return Setup(rod=rod, reference=shape, gravity=(0.0, 0.0, -G), contact=Contact(obstacles=bif))


def _along(angle, s, offset):
    """A point s [m] along the branch at ``angle`` from the junction, ``offset`` [m] to its left (+)
    in the xy-plane."""
    d = np.array([math.cos(angle), math.sin(angle), 0.0])
    return np.array([JUNCTION, 0.0, 0.0]) + s * d + offset * np.array([-d[1], d[0], 0.0])


def test_a_node_inside_either_tube_feels_no_wall_and_outside_both_the_nearer_wall_pushes_it_back():
    """Probes in the xy-plane (R = 6 mm, r = 2 mm, branches at +-35 degrees):

    * in the left branch 3.5 mm off its axis on the carina side, 40 mm from the junction: inside
      the left tube (gap 0.5 mm), 19 mm outside the right one: no force (a single vessel, the right
      one, would push it hard);
    * the same in the right branch: no force;
    * at the junction and just past it (inside both tubes): no force;
    * beyond the carina on the bisector, outside both tubes at the same depth: k |gap| straight back
      from the crease where the walls meet (the two normals blended: along -x), and 0.6 mm off the
      bisector, where one wall is 1 mm nearer (beyond the blend width r/4 = 0.5 mm), its normal;
    * in the left branch, 4.5 mm off its axis on the outer side (outside both): pushed back toward
      the left axis with k (4.5 - 4) mm;
    * in the trunk, 4.3 mm off the axis: pushed back toward the axis with k 0.3 mm."""
    bif = _y()
    probes = np.array([_along(ANGLE, 0.04, -0.0035), _along(-ANGLE, 0.04, +0.0035),
                       [JUNCTION, 0.0, 0.0], [JUNCTION + 0.004, 0.0, 0.0],
                       [JUNCTION + 0.03, 0.0, 0.0], _along(ANGLE, 0.04, +0.0045), [0.05, 0.0043, 0.0],
                       [JUNCTION + 0.03, 0.0006, 0.0]])
    force, k = _wrench(_probe_setup(bif, len(probes)), probes)
    radius = np.full(len(probes), R_ROD)
    gap, normal = bif.gap(probes, radius)
    inside = bif.inside(probes, R_ROD)
    assert inside[:4].tolist() == [[True, False], [False, True], [True, True], [True, True]]
    assert not inside[4:].any()
    assert np.array_equal(force[:4], np.zeros((4, 3)))
    single = [v.gap(probes[:2], radius[:2])[0] for v in bif.vessels]
    assert single[1][0] < -0.018 and single[0][1] < -0.018   # each alone would feel the other's wall
    # outside both: the reference's force, along the nearer tube's inward normal
    expected = -k[4:, None] * gap[4:, None] * normal[4:]
    assert np.allclose(force[4:], expected, rtol=1e-9, atol=0.0)
    assert gap[4] < 0 and gap[4] == pytest.approx(max(v.gap(probes[4:5], radius[4:5])[0][0] for v in bif.vessels))
    assert normal[4] == pytest.approx([-1.0, 0.0, 0.0], abs=1e-9)
    left = bif.vessels[0].gap(probes[7:], radius[7:])
    assert gap[7] == left[0][0] and np.allclose(normal[7], left[1][0], atol=1e-12) and normal[7, 1] > 0.8
    assert normal[5] @ np.array([math.cos(ANGLE + math.pi / 2), math.sin(ANGLE + math.pi / 2), 0]) == pytest.approx(-1)
    assert gap[5] == pytest.approx(-0.0005, abs=1e-6) and gap[6] == pytest.approx(-0.0003, abs=1e-6)
    assert normal[6] == pytest.approx([0.0, -1.0, 0.0], abs=1e-9)


def test_the_kernel_columns_hold_one_tube_each_and_a_plain_vessel_keeps_its_arrays():
    """A bifurcation takes two kernel columns (BIFURCATION, then BRANCH), each with
    its own polyline; a vessel beside it keeps the arrays it had alone."""
    bif, tube = _y(), Vessel([[-0.05, 0.0, 0.0], [0.3, 0.0, 0.0]], 0.02)
    setup = _probe_setup(bif, 5)
    both = kernel_arrays(Contact(obstacles=(tube, bif)), setup.rod, setup.gravity)
    alone = kernel_arrays(Contact(obstacles=tube), setup.rod, setup.gravity)
    assert both["contact_kind"].tolist() == [alone["contact_kind"][0], BIFURCATION, BRANCH]
    assert np.array_equal(both["contact_geom"][0], alone["contact_geom"][0])
    rows = both["contact_range"]
    assert np.array_equal(both["contact_points"][rows[2, 0]:rows[2, 0] + rows[2, 1]], bif.vessels[1].points)
    assert np.array_equal(both["contact_points"][:rows[0, 1]], alone["contact_points"])


class _Push:
    """Clamp motion: node 0 pushed along +x at speed V after a smooth start over T."""

    V, T = 0.25, 0.1

    def __init__(self, origin, rotation):
        self.origin, self.rotation = np.asarray(origin), np.asarray(rotation)

    def __call__(self, t):
        s = np.where(t < self.T, self.V * t**2 / (2 * self.T), self.V * (t - self.T / 2))
        return self.origin + s[:, None] * np.array([1.0, 0.0, 0.0]), np.broadcast_to(self.rotation, (t.size, 3, 3))


def _pushed(bif, integrator):
    """A rod of radius 2 mm resting on the trunk's floor, pushed 0.1 m along +x through the
    junction (x = 0.15 m) with friction 0.1, in gravity; the simulator and its four runs."""
    rest = 0.005 * R_ROD
    shape = straight(N, LENGTH, origin=(-0.04, 0.0, -(R_VESSEL - R_ROD) - rest), direction=(1.0, 0.0, 0.0),
                     normal=(0.0, 0.0, 1.0))
    setup = Setup(rod=_rod(), reference=shape, gravity=(0.0, 0.0, -G),
                  boundary=(Clamp(0, motion=_Push(shape.positions[0], shape.rotations[0])),),
                  contact=Contact(obstacles=bif, friction=0.1), damping=Damping(translational=0.2))
    sim = Simulator(setup)
    runs = []
    for _ in range(4):
        runs.append(sim.run(RunConfig(dt=1e-3, n_samples=101, integrator=integrator)))
        st = sim.state
        # the tracked segment of each tube is the brute-force closest one
        for c, v in enumerate(getattr(bif, "vessels", (bif,))):
            assert np.array_equal(st.contact_segment[:, c], closest_segments(v.points, st.positions)[0])
    return sim, runs


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
@pytest.mark.parametrize("straight_side", [0, 1], ids=["left-straight", "right-straight"])
def test_a_rod_pushed_through_the_trunk_follows_the_branch_in_line_and_stays_inside(integrator, straight_side):
    """The branch on the side ``straight_side`` continues the trunk, the other turns off at 35
    degrees: the rod pushed 0.1 m along the trunk passes the junction into the straight branch (its
    tip 5 cm past the junction, inside that tube and 2.9 cm from the other's axis), no node ever
    more than 1 % of r inside the wall, and each tube's tracked segment is the brute-force one."""
    turn = [JUNCTION + 0.1 * math.cos(ANGLE), 0.1 * math.sin(ANGLE) * (1 if straight_side else -1), 0.0]
    line = [JUNCTION + 0.1, 0.0, 0.0]
    arms = (line, turn) if straight_side == 0 else (turn, line)
    bif = Bifurcation([[-0.05, 0.0, 0.0], [JUNCTION, 0.0, 0.0]], [arms[0]], [arms[1]], R_VESSEL)
    _, runs = _pushed(bif, integrator)
    radius = np.full(N, R_ROD)
    for traj in runs:
        gaps = np.array([bif.gap(p, radius)[0] for p in traj.positions])
        assert gaps.min() > -0.01 * R_ROD
    tip = runs[-1].positions[-1, -1]
    assert tip[0] > JUNCTION + 0.05
    inside = bif.inside(tip, R_ROD * 0.9)[0]
    assert inside[straight_side] and not inside[1 - straight_side]
    assert np.abs(runs[-1].contact_forces).max() > 0


def test_a_bifurcation_with_two_equal_branches_is_that_vessel():
    """The union of a tube with itself is the tube: a rod pushed through a bifurcation whose
    branches are the same straight continuation moves as through the vessel of the same polyline
    (positions within 1e-12 m)."""
    bif = Bifurcation([[-0.05, 0.0, 0.0], [JUNCTION, 0.0, 0.0]], [[0.4, 0.0, 0.0]], [[0.4, 0.0, 0.0]], R_VESSEL)
    tube = Vessel([[-0.05, 0.0, 0.0], [JUNCTION, 0.0, 0.0], [0.4, 0.0, 0.0]], R_VESSEL)
    object.__setattr__(tube, "points", bif.vessels[0].points)   # the same polyline (no spline round-off)
    _, a = _pushed(bif, "implicit")
    _, b = _pushed(tube, "implicit")
    assert np.abs(a[-1].positions - b[-1].positions).max() < 1e-12
    assert np.abs(a[-1].contact_forces).max() > 0


@pytest.mark.parametrize("build, words", [
    (lambda: Bifurcation(np.zeros((1, 3)), [[1, 0, 0]], [[1, 1, 0]], 0.01), "bifurcation.trunk"),
    (lambda: Bifurcation([[0, 0, 0], [1, 0, 0]], [[1, 0, 0]], [[2, 1, 0]], 0.01), "bifurcation.left"),
    (lambda: Bifurcation([[0, 0, 0], [1, 0, 0]], [[2, 0, 0]], [[2, 1, 0], [2, 1, 0]], 0.01), "bifurcation.right"),
    (lambda: Bifurcation([[0, 0, 0], [1, 0, 0]], [[2, 0, 0]], [[2, 1, 0]], -0.01), "bifurcation.radius"),
    (lambda: Bifurcation([[0, 0, 0], [1, 0, 0]], [[2, 0, 0]], [[2, 1, 0]], 0.01, left_radius=[0.01, 0.01]),
     "bifurcation.left_radius"),
    (lambda: Bifurcation([[0, 0, 0], [1, 0, 0]], [[2, 0, 0]], [[2, 1, 0]], 0.01, friction=-1), "friction"),
])
def test_nonsense_bifurcations_are_refused_in_one_line(build, words):
    with pytest.raises(SoftrnnInputError) as err:
        build()
    assert "\n" not in str(err.value) and words in str(err.value)


def test_a_rod_wider_than_a_branch_or_starting_in_the_wall_is_refused():
    narrow = Bifurcation([[-0.05, 0.0, 0.0], [JUNCTION, 0.0, 0.0]], [[0.3, 0.05, 0.0]], [[0.3, -0.05, 0.0]],
                         R_VESSEL, right_radius=0.0015)
    with pytest.raises(SoftrnnInputError, match=r"contact\.obstacles\[0\]\.radius"):
        _probe_setup(narrow, 5)
    shape = straight(N, LENGTH, origin=(-0.04, 0.0, 0.0), direction=(0.0, 1.0, 0.0), normal=(0.0, 0.0, 1.0))
    with pytest.raises(SoftrnnInputError, match="inside obstacle 0 \\(Bifurcation\\)"):
        Setup(rod=_rod(), reference=shape, contact=Contact(obstacles=_y()))


def test_branch_radii_and_a_repeated_junction_point_are_understood():
    """A branch may repeat the junction as its first point (dropped); a branch radius defaults to
    the trunk's at the junction; one radius per point is interpolated along the branch."""
    b = Bifurcation([[0, 0, 0], [0.1, 0, 0]], [[0.1, 0, 0], [0.2, 0.05, 0]], [[0.2, -0.05, 0]], [0.01, 0.008],
                    right_radius=[0.005])
    assert b.left.tolist() == [[0.2, 0.05, 0.0]] and b.left_radius == 0.008
    assert b.vessels[0].radii[-1] == 0.008 and b.vessels[1].radii[-1] == 0.005
    assert np.array_equal(b.vessels[0].points[:b.trunk_rows], b.vessels[1].points[:b.trunk_rows])
    assert b.vessels[0].points[b.trunk_rows - 1].tolist() == [0.1, 0.0, 0.0]


def test_the_dataset_record_gives_the_same_bifurcation_back():
    bif = Bifurcation([[-0.05, 0, 0], [0.0, 0, 0], [JUNCTION, 0, 0]], [[0.2, 0.02, 0], [0.25, 0.06, 0]],
                      [[0.2, -0.02, 0]], [0.007, 0.0065, 0.006], left_radius=[0.005, 0.004], friction=0.2)
    record = json.loads(json.dumps(contact_record(Contact(obstacles=bif, friction=0.05))))
    entry = record["obstacles"][0]
    assert entry["kind"] == "bifurcation" and entry["friction"] == 0.2
    assert entry["left_radius"] == [0.005, 0.004] and entry["right_radius"] == 0.006
    back = contact_from_record(record).obstacles[0]
    assert isinstance(back, Bifurcation) and back.friction == 0.2
    for name in ("trunk", "left", "right", "radius", "left_radius", "right_radius"):
        assert np.array_equal(getattr(back, name), getattr(bif, name))
    for v, w in zip(back.vessels, bif.vessels):
        assert np.array_equal(v.points, w.points) and np.array_equal(v.radii, w.radii)
