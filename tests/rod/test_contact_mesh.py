"""Contact with a vessel given as a surface mesh (softrnn.geometry.mesh.MeshVessel): the kernels'
walk finds the exact gap of the NumPy reference along a path through the shipped arch near the
wall (and never a smaller one farther in), a rod comes
to rest on the floor of a meshed tube as in the analytic vessel (both integrators), a rod that starts
outside the lumen is refused, and the shipped scenario keeps its guidewire inside the arch."""

from importlib.resources import files

import numpy as np
import pytest
from numba import njit

from softrnn.errors import SoftrnnInputError
from softrnn.geometry._marching import tube_tree_surface
from softrnn.geometry.mesh import ARCH_FILE, arch_centrelines
from softrnn.rod import Contact, RodSpec, RunConfig, Setup, Simulator, Vessel, straight
from softrnn.rod.contact import MeshVessel, initial_segments, kernel_arrays, load_mesh
from softrnn.rod.contact_kernels import _obstacle_gap
from softrnn.rod.kernel_records import StepInputs
from softrnn.scenarios import load_scenario

SCENARIOS = files("softrnn.scenarios")
PENETRATION_TOL = 0.05        # of the rod radius: the goal for the mesh vessel


@njit(cache=False)
def _kernel_gaps(path, ra, inputs, out):
    """The kernels' gap and normal of each node of each step of ``path`` (S, n, 3), in order."""
    for s in range(path.shape[0]):
        for a in range(path.shape[1]):
            g, n0, n1, n2 = _obstacle_gap(a, 0, path[s, a, 0], path[s, a, 1], path[s, a, 2], ra, inputs)
            out[s, a, 0] = g
            out[s, a, 1] = n0
            out[s, a, 2] = n1
            out[s, a, 3] = n2


def _inputs(contact, start):
    rod = RodSpec(length=0.1, radius=0.0004, youngs_modulus=1e9, density=2000.0, n_nodes=start.shape[0])
    arrays = kernel_arrays(contact, rod, np.array([0.0, 0.0, -9.81]))
    return StepInputs(ext_idx=np.zeros(0, np.int64), ext_w=np.zeros((1, 0, 12)), pd_idx=np.zeros(0, np.int64),
                      pd_target=np.zeros((1, 0, 3)), pd_gain=np.zeros((0, 2)), presc_idx=np.zeros(0, np.int64),
                      presc_r=np.zeros((2, 0, 3)), presc_R=np.zeros((2, 0, 3, 3)),
                      contact_segment=initial_segments(contact, start), **arrays)


def test_the_kernels_walk_gives_the_exact_gap_along_a_path_through_the_arch():
    arch = load_mesh(f"{SCENARIOS}/{ARCH_FILE}", "m")
    line, radius = arch_centrelines()[0]
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, len(line) - 1.0, 1500)
    centre = np.stack([np.interp(t, np.arange(len(line)), line[:, i]) for i in range(3)], axis=1)
    angle = np.cumsum(rng.normal(0, 0.05, (len(t), 8)), axis=0)
    offset = radius * np.clip(0.9 + np.cumsum(rng.normal(0, 0.01, (len(t), 8)), axis=0), 0.6, 1.05)
    path = centre[:, None, :] + offset[..., None] * np.stack([np.cos(angle), np.sin(angle), 0 * angle], axis=-1)
    contact = Contact(obstacles=(arch,))
    inputs = _inputs(contact, path[0])
    out = np.zeros(path.shape[:2] + (4,))
    _kernel_gaps(path, 0.0004, inputs, out)
    gap, normal = arch.gap(path.reshape(-1, 3), np.full(path.shape[0] * path.shape[1], 0.0004))
    kernel = out[..., 0].reshape(-1)
    near = gap < 0.001                       # within 1 mm of touching (2.5 rod radii): exact
    assert near.sum() > 0.5 * len(gap) and (gap < 0).sum() > 0.2 * len(gap)
    np.testing.assert_allclose(kernel[near], gap[near], rtol=0, atol=1e-12)
    np.testing.assert_allclose(out[..., 1:].reshape(-1, 3)[near], normal[near], atol=1e-9)
    assert np.all(kernel >= gap - 1e-12)     # farther in, a walk may stop on a farther face: never a false touch


def _tube_setup(obstacle, n=9, length=0.04, r=0.0005):
    rod = RodSpec(length=length, radius=r, youngs_modulus=1e7, density=1500.0, n_nodes=n)
    shape = straight(n, length, origin=(0.01, 0.0, -0.002), direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    return Setup(rod=rod, reference=shape, gravity=(0.0, 0.0, -9.81), contact=Contact(obstacles=(obstacle,),
                                                                                     friction=0.2))


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_a_rod_comes_to_rest_on_the_floor_of_a_meshed_tube_as_in_the_analytic_vessel(integrator):
    R, r = 0.003, 0.0005
    axis = np.array([[0.0, 0, 0], [0.06, 0, 0]])
    v, f = tube_tree_surface([(axis, R)], 0.0006)
    runs = []
    for obstacle in (MeshVessel(v, f), Vessel(axis, R)):
        setup = _tube_setup(obstacle)
        traj = Simulator(setup).run(RunConfig(dt=0.005, n_samples=61, integrator=integrator))
        runs.append(traj.positions[-1])
    mesh_z, tube_z = runs[0][:, 2], runs[1][:, 2]
    assert np.all(np.abs(tube_z + (R - r)) < 0.01 * r)               # on the analytic floor
    mesh = MeshVessel(v, f)
    gaps = mesh.gap(runs[0], np.full(len(runs[0]), r))[0]
    assert gaps.min() > -PENETRATION_TOL * r and gaps.max() < 0.01 * r  # resting on the mesh, not sunk in it
    assert np.all(np.abs(mesh_z - tube_z) < 0.05 * r)


def test_a_rod_that_starts_outside_the_lumen_is_refused_in_one_line():
    v, f = tube_tree_surface([(np.array([[0.0, 0, 0], [0.06, 0, 0]]), 0.003)], 0.0008)
    rod = RodSpec(length=0.04, radius=0.0005, youngs_modulus=1e7, density=1500.0, n_nodes=9)
    shape = straight(9, 0.04, origin=(0.01, 0.0, 0.004), direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    with pytest.raises(SoftrnnInputError, match="inside obstacle 0 \\(MeshVessel\\)") as info:
        Setup(rod=rod, reference=shape, contact=Contact(obstacles=(MeshVessel(v, f),)))
    assert "\n" not in str(info.value)


def test_the_mesh_arch_guidewire_stays_inside_the_arch():
    """The first 0.6 s of 2.5: no node sinks 5 % of r into the mesh."""
    sc = load_scenario("mesh-arch-guidewire")
    arch = sc.setup.contact.obstacles[0]
    r = sc.setup.rod.radius
    traj = Simulator(sc.setup).run(RunConfig(dt=sc.config.dt, n_samples=121, integrator=sc.config.integrator))
    gaps = np.array([arch.gap(p, np.full(len(p), r))[0] for p in traj.positions[::10]])
    assert gaps.min() > -PENETRATION_TOL * r
    pushed = traj.positions[-1, 0, 2] - traj.positions[0, 0, 2]
    assert pushed > 0.015 and traj.positions[-1, -1, 2] - traj.positions[0, -1, 2] > 0.5 * pushed
