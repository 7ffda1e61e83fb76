"""Devices of several materials: the lumping of a material table (mass, inertia and series stiffness
at a section boundary), a two-material cantilever's tip deflection against Euler-Bernoulli (with
shear) in both integrators, a pre-shaped tip at rest and released, energy with mixed materials, the
shapes with bends, the guidewire helper, the data-set record and the one-line errors of a material
table that does not tile the rod."""

import dataclasses

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import read_dataset, write_trajectory
from softrnn.rod import (
    Bend,
    Clamp,
    Constant,
    Damping,
    MaterialSection,
    NodalLoad,
    NodeOverride,
    RodSpec,
    RunConfig,
    Setup,
    Simulator,
    arc,
    curved,
    guidewire,
    shaped_tip,
    straight,
)
from softrnn.rod.discrete import internal_loads, segment_strains
from softrnn.rod.materials import check_cover
from softrnn.statics import static_start

from helpers import planar_bent_shape

L, R, E1, RHO, NU = 0.2, 0.002, 2e6, 1000.0, 0.5
TIP_RTOL = 0.01          # settled tip deflection vs the closed form at 21 nodes (measured 1.5e-3, 2.0e-3)
REST_TOL = 1e-10         # largest move / L of a pre-shaped rod started in its rest shape
RETURN_TOL = 1e-4        # a pre-shaped rod released from straight settles back to its shape (/ L)
ENERGY_BOUND = 5e-3      # max |E - E0| / energy exchanged, undamped, two materials (measured 1.7e-3)
ENERGY_DRIFT = 2e-4      # |mean of the last tenth - first tenth| / energy exchanged (measured 5e-5)


def two_materials(n=21, boundary=0.1, E2=E1 / 8, rho2=RHO, r2=R, **kw) -> RodSpec:
    """A rod of E1 up to ``boundary`` [m] and E2 (density rho2, radius r2) beyond it."""
    return RodSpec(length=L, radius=R, youngs_modulus=E1, density=RHO, n_nodes=n, poisson_ratio=NU,
                   sections=(MaterialSection(start=0.0, end=boundary),
                             MaterialSection(start=boundary, end=L, youngs_modulus=E2, density=rho2, radius=r2)),
                   **kw)


def tip_compliance(a, E2) -> float:
    """Tip deflection per tip force [m/N] of a cantilever of E1 on [0, a], E2 on [a, L] (radius R):
    bending int (L - s)^2 / EI ds plus shear int 1 / (G A) ds."""
    A, I = np.pi * R**2, np.pi * R**4 / 4
    G1, G2 = E1 / (2 * (1 + NU)), E2 / (2 * (1 + NU))
    bending = (L**3 - (L - a) ** 3) / (3 * E1 * I) + (L - a) ** 3 / (3 * E2 * I)
    return bending + a / (G1 * A) + (L - a) / (G2 * A)


# --------------------------------------------------------------------------- lumping
def test_a_section_boundary_inside_a_cell_splits_mass_inertia_and_stiffness():
    """Boundary at 0.043 m, n = 11 (l = 0.02): node 2's share [0.03, 0.05] is 0.013 m of the first
    section and 0.007 m of the second; segment 2 [0.04, 0.06] is 0.003 m and 0.017 m."""
    rod = RodSpec(length=L, radius=R, youngs_modulus=E1, density=RHO, n_nodes=11, poisson_ratio=NU,
                  sections=(MaterialSection(start=0.0, end=0.043),
                            MaterialSection(start=0.043, end=L, radius=2 * R, inner_radius=R, youngs_modulus=5 * E1,
                                            density=3 * RHO)))
    lump = rod.lumped()
    A1, I1 = np.pi * R**2, np.pi * R**4 / 4
    A2, I2 = np.pi * 3 * R**2, np.pi * 15 * R**4 / 4          # the tube (2R, R)
    mu1, mu2 = RHO * A1, 3 * RHO * A2
    assert lump["mass"].sum() == pytest.approx(mu1 * 0.043 + mu2 * (L - 0.043), rel=1e-13)
    assert lump["mass"][0] == pytest.approx(mu1 * 0.01, rel=1e-13)
    assert lump["mass"][2] == pytest.approx(mu1 * 0.013 + mu2 * 0.007, rel=1e-13)
    assert lump["mass"][-1] == pytest.approx(mu2 * 0.01, rel=1e-13)
    assert lump["inertia"][2] == pytest.approx(np.array([1, 1, 2]) * RHO * (I1 * 0.013 + 3 * I2 * 0.007), rel=1e-13)
    EI1, EI2 = E1 * I1, 5 * E1 * I2
    assert lump["C2"][2, 0] == pytest.approx(1.0 / (0.15 / EI1 + 0.85 / EI2), rel=1e-13)  # in series
    assert lump["C2"][1, 0] == EI1 and lump["C2"][3, 0] == EI2
    assert lump["C1"][3, 2] == pytest.approx(5 * E1 * A2, rel=1e-15)
    props = rod.node_properties()
    assert props["radius"][2] == R and props["radius"][3] == 2 * R and props["inner"][3] == R


def test_identical_sections_lump_as_the_one_material_rod():
    uniform = RodSpec(length=L, radius=R, youngs_modulus=E1, density=RHO, n_nodes=15)
    split = dataclasses.replace(uniform, sections=tuple(MaterialSection(start=a, end=b)
                                                        for a, b in ((0.0, 0.05), (0.05, 0.137), (0.137, L))))
    a, b = uniform.lumped(), split.lumped()
    for key in ("mass", "inertia", "C1", "C2"):
        np.testing.assert_allclose(b[key], a[key], rtol=1e-13, atol=0)


def test_overrides_apply_on_top_of_the_sections():
    rod = two_materials(overrides=(NodeOverride(first=3, last=5, youngs_modulus=1e9, density=8000.0),))
    lump, plain = rod.lumped(), two_materials().lumped()
    l = rod.segment_length
    assert lump["mass"][4] == pytest.approx(8000.0 * np.pi * R**2 * l, rel=1e-13)
    assert lump["C2"][3, 0] == pytest.approx(1e9 * np.pi * R**4 / 4, rel=1e-13)
    np.testing.assert_array_equal(lump["C2"][10:], plain["C2"][10:])


# --------------------------------------------------------------------------- statics through the dynamics
def _cantilever(rod, P, integrator):
    setup = Setup(rod=rod, reference=straight(rod.n_nodes, L, direction=(1, 0, 0), normal=(0, 0, 1)),
                  boundary=(Clamp(0),), loads=(NodalLoad(-1, force=Constant((0.0, 0.0, P))),),
                  damping=Damping(translational=0.07, rotational=1e-6))  # about critical for the first mode
    traj = Simulator(setup).run(RunConfig(dt=0.5, n_samples=11, save_nodes=(-1,), integrator=integrator))
    return traj.positions[:, 0, 2]


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_a_two_material_cantilever_deflects_as_the_sum_of_its_sections(integrator):
    """A tip force P on a cantilever of E1 on the first half and E1/8 on the second: the settled
    tip deflection is P (sum of the sections' bending and shear compliances), 1.9x that of the
    rod of E1 alone; the load is small (deflection 1e-3 L)."""
    c = tip_compliance(0.1, E1 / 8)
    assert c > 1.8 * tip_compliance(0.1, E1)  # the soft half dominates: a one-material rod fails this
    P = 1e-3 * L / c
    z = _cantilever(two_materials(), P, integrator)
    assert abs(z[-1] - z[-2]) < 1e-3 * abs(z[-1])  # settled
    assert z[-1] == pytest.approx(P * c, rel=TIP_RTOL)


def test_a_boundary_inside_a_segment_deflects_as_the_closed_form():
    a = 0.105  # halfway along segment 10
    c = tip_compliance(a, E1 / 8)
    P = 1e-3 * L / c
    z = _cantilever(two_materials(boundary=a), P, "implicit")
    assert z[-1] == pytest.approx(P * c, rel=TIP_RTOL)


def test_the_two_material_mismatch_is_the_discretisation_and_shrinks_with_the_node_spacing_squared():
    c = tip_compliance(0.1, E1 / 8)
    P = 1e-3 * L / c
    err = [abs(_cantilever(two_materials(n=n), P, "implicit")[-1] / (P * c) - 1.0) for n in (21, 41)]
    assert 3.0 < err[0] / err[1] < 5.0  # measured 1.5e-3 and 3.8e-4


# --------------------------------------------------------------------------- pre-shaped tips
def _hooked(n=41, **kw):
    rod = two_materials(n=n, boundary=0.15, E2=E1 / 4, rho2=600.0)
    ref = shaped_tip(n, L, angle_deg=180.0, bend_length=0.03, tip_length=0.005, direction=(1, 0, 0),
                     normal=(0, 0, 1))
    return Setup(rod=rod, reference=ref, boundary=(Clamp(0),), **kw)


def test_a_pre_shaped_tip_has_no_elastic_forces_in_its_rest_shape():
    setup = _hooked()
    lump = setup.rod.lumped()
    l = setup.rod.segment_length
    ref = setup.reference
    K0, G0 = segment_strains(ref.rotations, ref.positions, l)
    assert np.abs(K0[:, 1]).max() > 50.0  # it is bent (pi / 0.03 m)
    f, t = internal_loads(ref.rotations, ref.positions, l, lump["C1"], lump["C2"], K0, G0)
    assert np.abs(f).max() == 0.0 and np.abs(t).max() == 0.0


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_a_pre_shaped_tip_at_rest_stays_at_rest(integrator):
    setup = _hooked()
    traj = Simulator(setup).run(RunConfig(dt=0.01, n_samples=21, integrator=integrator))
    move = np.linalg.norm(traj.positions - setup.reference.positions, axis=2).max() / L
    assert move < REST_TOL


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_a_pre_shaped_cantilever_released_from_straight_returns_to_its_shape(integrator):
    """No gravity: held straight, then let go, the hooked tip swings back into its rest shape."""
    n = 41
    setup = _hooked(n, initial=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)),
                    damping=Damping(translational=0.15, rotational=1e-6))
    traj = Simulator(setup).run(RunConfig(dt=0.5, n_samples=11, integrator=integrator))
    ref = setup.reference.positions
    assert np.linalg.norm(traj.positions[1] - ref, axis=1).max() > 10 * RETURN_TOL * L  # on its way
    assert np.linalg.norm(traj.positions[-1] - ref, axis=1).max() / L < RETURN_TOL


def _energy_error(setup, h, steps):
    traj = Simulator(setup).run(RunConfig(dt=100 * h, n_samples=steps // 100 + 1, substeps=100))
    total = traj.energy.sum(axis=1)
    return (total - total[0]) / np.ptp(traj.energy[:, 1])


def test_undamped_energy_is_bounded_with_mixed_materials():
    """A two-material cantilever (boundary inside a segment; the outer part thinner, 5x softer and
    3x denser) released from a bent shape, undamped: the energy error of the symplectic scheme is
    bounded, without drift, and quarters when the step halves (measured 1.7e-3 of the energy
    exchanged, 4.4x; a uniform rod 0.6e-3, the same materials as a NodeOverride 1.9e-3)."""
    n = 15
    rod = RodSpec(length=L, radius=0.005, youngs_modulus=1e6, density=RHO, n_nodes=n,
                  sections=(MaterialSection(start=0.0, end=0.123),
                            MaterialSection(start=0.123, end=L, radius=0.004, youngs_modulus=2e5, density=3 * RHO)))
    s = np.linspace(0.0, L, n)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                  initial=planar_bent_shape(0.3 / L**2 * (L * s - s**2 / 2), L / (n - 1)))  # tip 0.1 L down
    h = Simulator(setup).stable_step()
    err = _energy_error(setup, h, 50_000)
    tenth = err.size // 10
    assert np.abs(err).max() < ENERGY_BOUND
    assert abs(err[-tenth:].mean() - err[:tenth].mean()) < ENERGY_DRIFT
    assert 3.0 < np.abs(err).max() / np.abs(_energy_error(setup, h / 2, 100_000)).max() < 5.5


# --------------------------------------------------------------------------- shapes
def test_bent_shapes_are_exact_curves():
    n = 21
    assert np.allclose(curved(n, L, (), direction=(1, 0, 0), normal=(0, 0, 1)).positions,
                       straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)).positions, rtol=0, atol=1e-15)
    bent = curved(n, L, (Bend(0.0, L, 1 / 0.1),), direction=(0, 1, 0), normal=(1, 0, 0))
    circle = arc(n, L, 0.1, tangent=(0, 1, 0), inward=(1, 0, 0))
    np.testing.assert_allclose(bent.positions, circle.positions, rtol=0, atol=1e-14)
    np.testing.assert_allclose(bent.rotations, circle.rotations, rtol=0, atol=1e-14)
    j = shaped_tip(n, L, angle_deg=180.0, bend_length=0.05, toward_deg=90.0, direction=(1, 0, 0), normal=(0, 0, 1))
    np.testing.assert_allclose(j.rotations[-1][:, 2], [-1, 0, 0], atol=1e-14)  # turned back on itself
    d2 = j.rotations[0][:, 1]
    assert np.dot(j.positions[-1] - j.positions[0], d2) == pytest.approx(2 * 0.05 / np.pi, rel=1e-12)


def test_the_guidewire_has_a_soft_shaped_tip_and_starts_at_rest():
    wire = guidewire(1.0, 201, shape="j")
    lump = wire.rod.lumped()
    body, tip = lump["C2"][0, 0], lump["C2"][-1, 0]
    assert 10 < body / tip < 100
    assert wire.rod.sections[-1].density < wire.rod.sections[0].density
    assert len(wire.rod.sections) == 4 and wire.rod.sections[-1].start == pytest.approx(0.96)
    K0, G0 = segment_strains(wire.reference.rotations, wire.reference.positions, wire.rod.segment_length)
    assert np.abs(K0[-4:, 1]).max() > 100 and np.abs(K0[:150]).max() < 1e-12
    f, t = internal_loads(wire.reference.rotations, wire.reference.positions, wire.rod.segment_length,
                          lump["C1"], lump["C2"], K0, G0)
    assert np.abs(f).max() == 0.0 and np.abs(t).max() == 0.0
    assert np.allclose(guidewire(shape="straight").reference.positions[:, :2], 0.0)
    with pytest.raises(SoftrnnInputError, match=r"n_nodes=101 is invalid: at least \d+ nodes"):
        guidewire(1.0, 101, shape="angled")
    own = guidewire(0.5, 101, bend=(90.0, 0.02, 0.01), direction=(1, 0, 0), normal=(0, 0, 1)).reference
    np.testing.assert_allclose(own.rotations[-1][:, 2], [0, 0, 1], atol=1e-14)  # turned 90 degrees toward +z
    with pytest.raises(SoftrnnInputError, match="bend"):
        guidewire(bend=(90.0, 0.0, 0.0))


# --------------------------------------------------------------------------- record and errors
def test_a_data_set_carries_the_material_table(tmp_path):
    rod = two_materials(n=5)
    setup = Setup(rod=rod, reference=straight(5, L), boundary=(Clamp(0),))
    traj = Simulator(setup).run(RunConfig(dt=0.01, n_samples=3))
    write_trajectory(tmp_path / "a.h5", traj, dt=0.01, rod=rod)
    assert read_dataset(tmp_path / "a.h5").rod_spec() == rod
    plain = dataclasses.replace(rod, sections=())
    write_trajectory(tmp_path / "b.h5", traj, dt=0.01, rod=plain)
    ds = read_dataset(tmp_path / "b.h5")
    assert ds.attrs["rod"]["sections"] == [] and ds.rod_spec() == plain


@pytest.mark.parametrize("spans, words", [
    ([(0.0, 0.1), (0.08, L)], ["sections[1].start=0.08", "overlap"]),
    ([(0.0, 0.1), (0.12, L)], ["sections[1].start=0.12", "gap [0.1, 0.12]"]),
    ([(0.01, L)], ["sections[0].start=0.01", "uncovered"]),
    ([(0.0, 0.1), (0.1, 0.15)], ["sections[1].end=0.15", "[0.15, 0.2] m uncovered"]),
    ([(0.0, 0.1), (0.1, 0.3)], ["sections[1].end=0.3", "beyond the rod's end"]),
])
def test_a_material_table_that_does_not_tile_the_rod_is_refused_in_one_line(spans, words):
    with pytest.raises(SoftrnnInputError) as err:
        RodSpec(length=L, radius=R, youngs_modulus=E1, density=RHO, n_nodes=5,
                sections=tuple(MaterialSection(start=a, end=b) for a, b in spans))
    msg = str(err.value)
    assert "\n" not in msg and all(w in msg for w in words) and "tile [0, 0.2] m" in msg


def test_bad_sections_and_bends_name_the_value():
    for kw, word in ((dict(start=0.1, end=0.1), "start < end"), (dict(start=0, end=1, radius=-1), "radius"),
                     (dict(start=0, end=1, radius=1e-3, inner_radius=1e-3), "inner_radius"),
                     (dict(start=0, end=1, poisson_ratio=0.7), "poisson_ratio")):
        with pytest.raises(SoftrnnInputError, match=word):
            MaterialSection(**kw)
    with pytest.raises(SoftrnnInputError, match="inner_radius"):  # the rod's radius below a section's inner one
        RodSpec(length=L, radius=R, youngs_modulus=E1, density=RHO, n_nodes=5,
                sections=(MaterialSection(start=0, end=L, inner_radius=2 * R),))
    with pytest.raises(SoftrnnInputError, match="curvature"):
        Bend(0.0, 0.1, 0.0)
    with pytest.raises(SoftrnnInputError, match=r"bends\[1\].start.*not overlapping"):
        curved(5, L, (Bend(0.0, 0.1, 1.0), Bend(0.05, 0.15, 1.0)))
    with pytest.raises(SoftrnnInputError, match=r"sections\[0\].start"):
        check_cover([], L)


def test_a_static_start_refuses_a_rod_of_several_materials():
    setup = Setup(rod=two_materials(), reference=straight(21, L), boundary=(Clamp(0),))
    with pytest.raises(SoftrnnInputError, match="rod.sections"):
        static_start(setup)
