"""Scenario files: the shipped scenarios load and equal the Python-built paper cases; variants are
deterministic; bad files give one-line errors naming the file and the key; the new target paths."""

import json
from dataclasses import replace
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import (
    Clamp,
    Constant,
    Damping,
    NodalLoad,
    PDTracking,
    RodSpec,
    RunConfig,
    Setup,
    Simulator,
    SquarePath,
    Window,
    arc,
    ellipse,
    straight,
)
from softrnn.rod.loads import CirclePath, Figure8Path, RandomSmoothPath, Sinusoid
from softrnn.rod.shapes import ellipse_perimeter
from softrnn.scenarios.cases import ASSUMPTIONS, CASE_NAMES, PAPER_CASES, build_case
from softrnn.scenarios.paths import PoseMotion, rotation_vector_to_matrix
from softrnn.scenarios.scenario import (
    SCENARIO_NAMES,
    Scenario,
    ScenarioError,
    load_scenario,
    parse_scenario,
    scenario_text,
)

T_GRID = np.arange(0.0, 3.0, 1e-3)


# --------------------------------------------------------------------------- the cases as they were
def _legacy(name):
    """The paper cases as softrnn.scenarios.cases built them in Python before the scenario files (verbatim
    values), as (setup, config, node_of_interest, paper_key, paper_section)."""
    def rubber(length, radius, n):
        return RodSpec(length=length, radius=radius, youngs_modulus=2.5e6, density=1000.0, n_nodes=n,
                       poisson_ratio=0.5)
    drag = Damping(translational=0.01, rotational=1e-6)
    if name.startswith("ellipse"):
        n, length = 59, ellipse_perimeter(0.2, 0.6)
        w, h = (0.2, 0.6) if name == "ellipse" else (0.6, 0.2)
        setup = Setup(rod=rubber(length, 0.005, n), initial=ellipse(n, w, h),
                      reference=straight(n, length, direction=(1.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0)),
                      boundary=(Clamp(0), Clamp(n - 1)), damping=drag)
        return setup, RunConfig(dt=1e-3, n_samples=50001), 30, "ellipse", "4.1"
    if name.startswith("square"):
        n = 51
        target = (SquarePath(center=(0.5, 0.0, 0.0), side=0.2, period=8.0) if name == "square"
                  else CirclePath(center=(0.5, 0.0, 0.0), radius=0.1, period=6.0))
        setup = Setup(rod=rubber(0.5, 0.01, n), boundary=(Clamp(0),), damping=drag,
                      reference=straight(n, 0.5, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)),
                      loads=(PDTracking(n - 1, target, stiffness=5.0, damping=1.0),))
        return setup, RunConfig(dt=1e-4, n_samples=160001), n - 1, "square_tip", "4.2"
    n, length = 101, 0.6
    if name == "semicircle":
        load = NodalLoad(50, force=Window(Constant((0.0, -1.0, 0.0)), 0.0, 0.5))
    else:
        load = NodalLoad(50, force=Window(Sinusoid((0.0, 0.0, -0.1), 0.5, phase=np.pi / 2), 1.0, 2.0 + 1e-9))
    setup = Setup(rod=rubber(length, 0.02, n), boundary=(Clamp(0), Clamp(n - 1)), loads=(load,), damping=drag,
                  reference=arc(n, length, length / np.pi, tangent=(0.0, 1.0, 0.0), inward=(1.0, 0.0, 0.0)),
                  gravity=(0.0, 0.0, -9.81))
    return setup, RunConfig(dt=1e-4, n_samples=20001), 50, "semicircle", "4.3"


def _load_values(load, t):
    fn = load.target if isinstance(load, PDTracking) else (load.force if load.force is not None else load.torque)
    return fn(t)


LEGACY = ("ellipse", "ellipse-horizontal", "square", "square-circle", "semicircle", "semicircle-cosine")


@pytest.mark.parametrize("name", LEGACY)
def test_paper_cases_equal_the_python_built_setups(name):
    setup, config, node, key, section = _legacy(name)
    case = build_case(name)
    s = case.setup
    assert s.rod == setup.rod
    for which in ("reference", "initial"):
        np.testing.assert_array_equal(getattr(s, which).positions, getattr(setup, which).positions)
        np.testing.assert_array_equal(getattr(s, which).rotations, getattr(setup, which).rotations)
    assert [type(b) for b in s.boundary] == [type(b) for b in setup.boundary]
    assert [b.node for b in s.boundary] == [b.node for b in setup.boundary]
    assert all(b.motion is None for b in s.boundary)
    assert s.loads == setup.loads  # dataclass equality: same kinds, nodes, gains, profile parameters
    for mine, theirs in zip(s.loads, setup.loads):
        np.testing.assert_array_equal(_load_values(mine, T_GRID), _load_values(theirs, T_GRID))
    assert s.damping == setup.damping and s.gravity == setup.gravity
    assert case.config == config
    assert (case.node_of_interest, case.paper_key, case.paper_section) == (node, key, section)


def test_a_paper_case_simulates_exactly_as_before():
    setup, config, *_ = _legacy("semicircle")
    cfg = RunConfig(dt=config.dt, n_samples=20)
    before = Simulator(setup).run(cfg)
    after = Simulator(build_case("semicircle").setup).run(cfg)
    np.testing.assert_array_equal(after.positions, before.positions)
    np.testing.assert_array_equal(after.quaternions, before.quaternions)


def test_assumptions_come_from_the_files():
    for key in ("material", "damping", "ellipse", "square", "semicircle"):
        assert len(ASSUMPTIONS[key]) > 40
    # the shared assumptions read the same in every file of the urethane rods; the stiff wires
    # (steel, nitinol) and the magnetic manipulator (PMC-770, its own damping) state their own under
    # other keys
    for name in SCENARIO_NAMES:
        sc = load_scenario(name)
        urethane = sc.magnetic is None and sc.setup.rod.youngs_modulus == 2.5e6
        for key in ("material", "damping"):
            if urethane:
                assert sc.assumptions[key] == ASSUMPTIONS[key], (name, key)
            else:
                assert key not in sc.assumptions, (name, key)
    assert set(PAPER_CASES) <= set(CASE_NAMES) and CASE_NAMES == SCENARIO_NAMES


# --------------------------------------------------------------------------- every shipped file
def test_shipped_files_are_the_scenario_names():
    folder = resources.files("softrnn").joinpath("scenarios")
    shipped = sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))
    assert shipped == sorted(SCENARIO_NAMES)


@pytest.mark.parametrize("name", SCENARIO_NAMES)
def test_every_shipped_scenario_loads_and_builds(name):
    sc = load_scenario(name)
    assert isinstance(sc, Scenario)
    assert sc.name == name and sc.source == f"builtin:{name}" and sc.title
    assert sc.text == scenario_text(name) and sc.data["name"] == name
    assert sc.paper.get("section", "4.1") in ("4.1", "4.2", "4.3")  # the tendon arms are not the paper's
    assert sc.paper["role"] in ("training", "generalisation")
    assert sc.seed >= 0 and sc.variant_index is None and sc.sampled == {}
    n = sc.setup.rod.n_nodes
    assert all(0 <= a < n for a in sc.nodes_of_interest)
    for load in sc.setup.loads:
        values = _load_values(load, T_GRID)
        assert values.shape == (T_GRID.size, 3) and np.all(np.isfinite(values))
    if sc.paper["role"] == "training":
        assert sc.randomized  # every training case declares what a sweep varies


def test_generalisation_variants():
    cos = build_case("semicircle-cosine").setup.loads[0]
    t = np.array([0.5, 1.0, 1.25, 1.5, 2.0, 2.5])
    inside = (t >= 1.0) & (t <= 2.0)  # [0, 0, -100 cos(pi t)] mN on t in [1, 2] s
    np.testing.assert_allclose(cos.force(t)[:, 2], np.where(inside, -0.1 * np.cos(np.pi * t), 0.0), atol=1e-12)
    assert np.all(cos.force(t)[:, :2] == 0)
    assert cos.node == 50  # the paper's node 51
    wide = build_case("ellipse-horizontal").setup.initial.positions
    assert np.ptp(wide[:, 0]) == pytest.approx(0.6, abs=0.01) and np.ptp(wide[:, 1]) == pytest.approx(0.2, abs=0.01)
    for name, cls in (("square-figure8", Figure8Path), ("square-random", RandomSmoothPath)):
        assert isinstance(build_case(name).setup.loads[0].target, cls)


# --------------------------------------------------------------------------- variants
def test_variants_are_deterministic_and_differ():
    sc = load_scenario("square")
    a, b, c = sc.variant(4), sc.variant(4), sc.variant(5)
    assert a.data == b.data and a.sampled == b.sampled and a.variant_index == 4
    assert set(a.sampled) == set(c.sampled) and all(a.sampled[k] != c.sampled[k] for k in a.sampled)
    np.testing.assert_array_equal(_load_values(a.setup.loads[0], T_GRID), _load_values(b.setup.loads[0], T_GRID))
    assert a.setup.loads[0].stiffness == a.sampled["loads.0.stiffness"]
    assert json.loads(json.dumps(a.sampled)) == a.sampled
    # a variant of a variant starts from the base scenario again, and reloading gives the same draws
    assert a.variant(5).sampled == c.sampled == load_scenario("square").variant(5).sampled
    assert parse_scenario(sc.text, sc.source).variant(4).data == a.data


@pytest.mark.parametrize("name", [n for n in SCENARIO_NAMES if load_scenario(n).randomized])
def test_a_variant_builds_and_runs(name):
    v = load_scenario(name).variant(1)
    if v.magnetic is not None:  # the magnetic manipulator runs on its own driver (every node saved)
        from softrnn.scenarios.magnetic import simulate_magnetic

        traj = simulate_magnetic(v.magnetic, replace(v.config, n_samples=4))
        assert np.all(np.isfinite(traj.positions)) and traj.currents.shape == (4, 6)
        return
    traj = Simulator(v.setup).run(replace(v.config, n_samples=4, save_nodes=v.nodes_of_interest))
    assert np.all(np.isfinite(traj.positions))


def test_ellipse_variants_keep_the_rod_length():
    sc = load_scenario("ellipse")
    length = sc.setup.rod.length
    widths = set()
    for i in range(3):
        init = sc.variant(i).setup.initial
        assert init.arc_length() == pytest.approx(length, rel=2e-3)
        widths.add(round(float(np.ptp(init.positions[:, 0])), 6))
    assert len(widths) == 3


def test_a_scenario_without_randomize_has_no_variants():
    sc = load_scenario("semicircle-cosine")
    assert not sc.randomized
    with pytest.raises(SoftrnnInputError, match="builtin:semicircle-cosine: randomize"):
        sc.variant(0)
    with pytest.raises(SoftrnnInputError, match="variant index"):
        load_scenario("semicircle").variant(-1)


# --------------------------------------------------------------------------- the format
MINIMAL = """
name = "mini"
seed = 3
[rod]
length = 0.3
radius = 0.005
youngs_modulus = 1e6
density = 1000.0
n_nodes = 11
[reference]
kind = "straight"
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[boundary]]
kind = "clamp"
node = 0
[[loads]]
kind = "force"
node = -1
profile = { kind = "sinusoid", amplitude = [0.0, 0.0, 0.01], frequency = 2.0 }
[run]
dt = 1e-3
duration = 0.05
substeps = "auto"
nodes_of_interest = [-1]
"""


def _write(tmp_path, text, name="case.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_documented_example_loads_and_varies(tmp_path):
    doc = (Path(__file__).resolve().parents[2] / "docs" / "scenario-format.md").read_text()
    example = doc[doc.index('```toml\nname = "whip"') + len("```toml\n"):]
    sc = load_scenario(_write(tmp_path, example[:example.index("```")]))
    assert sc.config.n_samples == 5001 and sc.nodes_of_interest == (40, 20)
    assert isinstance(sc.setup.boundary[0].motion, PoseMotion) and sc.variant(0).sampled


def test_minimal_file_defaults_and_duration(tmp_path):
    sc = load_scenario(_write(tmp_path, MINIMAL))
    assert sc.name == "mini" and sc.title == "mini" and sc.seed == 3 and sc.paper == {}
    assert sc.config.n_samples == 51 and sc.config.substeps is None and sc.nodes_of_interest == (10,)
    assert sc.setup.gravity == (0.0, 0.0, 0.0) and sc.setup.initial is sc.setup.reference
    assert sc.source == str(tmp_path / "case.toml")


def test_files_profiles_motions_and_nested_randomize(tmp_path):
    (tmp_path / "shape.csv").write_text("x, y, z\n" + "\n".join(f"{0.03 * i}, 0, 0" for i in range(11)))
    (tmp_path / "push.csv").write_text("# t, fx, fy, fz\n0, 0, 0, 0\n0.02, 0, 0.01, 0\n0.04, 0, 0, 0\n")
    text = MINIMAL.replace('kind = "straight"\ndirection = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]',
                          'kind = "polyline"\nfile = "shape.csv"\nnormal = [0.0, 0.0, 1.0]')
    text = text.replace('node = 0\n', 'node = 0\ndisplacement = { kind = "sinusoid", amplitude = [0.0, 0.001, 0.0], '
                                     'frequency = 1.0 }\nrotation = { kind = "constant", value = [0.0, 0.0, 0.01] }\n')
    text += """
[[loads]]
kind = "force"
node = 5
profile = { kind = "sampled", file = "push.csv" }
[[loads]]
kind = "pd"
node = 8
stiffness = 2.0
target = { kind = "figure8", center = [0.24, 0.0, 0.0], width = 0.02, height = 0.01, period = 1.0 }
[randomize]
loads.0.profile.frequency = { uniform = [1.0, 3.0] }
"loads.2.target" = { choice = [
    { kind = "circle", center = [0.24, 0.0, 0.0], radius = 0.01, period = 1.0 },
    { kind = "random_smooth", center = [0.24, 0.0, 0.0], amplitude = 0.01, cutoff = 1.0, seed = 4 }] }
"run.substeps" = { integers = [8, 12] }
"""
    sc = load_scenario(_write(tmp_path, text))
    clamp = sc.setup.boundary[0]
    assert isinstance(clamp.motion, PoseMotion)
    pos, rot = clamp.motion(np.array([0.0, 0.25]))
    np.testing.assert_allclose(pos[1], [0.0, 0.001, 0.0], atol=1e-15)
    np.testing.assert_allclose(rot[0],
                               rotation_vector_to_matrix(np.array([0, 0, 0.01])) @ sc.setup.initial.rotations[0])
    np.testing.assert_allclose(sc.setup.loads[1].force(np.array([0.01, 0.02, 0.05]))[:, 1], [0.005, 0.01, 0.0])
    v = sc.variant(2)
    assert set(v.sampled) == {"loads.0.profile.frequency", "loads.2.target", "run.substeps"}
    assert v.config.substeps == v.sampled["run.substeps"]
    traj = Simulator(v.setup).run(RunConfig(dt=v.config.dt, n_samples=5, substeps=v.config.substeps))
    assert np.all(np.isfinite(traj.positions))


# --------------------------------------------------------------------------- errors
def _error(tmp_path, text) -> str:
    path = _write(tmp_path, text)
    with pytest.raises(SoftrnnInputError) as info:
        load_scenario(str(path))
    message = str(info.value)
    assert len(message.splitlines()) == 1, message
    assert message.startswith(f"{path}: "), message
    return message


@pytest.mark.parametrize("change, words", [
    (("[rod]", "[rod"), ["malformed TOML", "line"]),
    (("radius = 0.005", "radiuss = 0.005"), ["unknown key 'rod.radiuss'", "expected one of", "did you mean 'radius'"]),
    (('name = "mini"', 'name = "mini"\ncolour = "red"'), ["unknown key 'colour'"]),
    (("radius = 0.005", "radius = 'a'"), ["rod.radius = 'a' is invalid", "expected a positive number in m"]),
    (("n_nodes = 11", "n_nodes = 11.5"), ["rod.n_nodes = 11.5", "integer"]),
    (("length = 0.3\n", ""), ["missing key 'rod.length'"]),
    (("duration = 0.05", "duration = -1.0"), ["run.duration = -1.0", "positive"]),
    (("duration = 0.05", "n_samples = 0"), ["run.n_samples = 0", ">= 1"]),
    (("duration = 0.05", "duration = 0.05\nn_samples = 5"), ["duration or n_samples, not both"]),
    (("duration = 0.05\n", ""), ["missing key 'run.duration'", "n_samples"]),
    (("nodes_of_interest = [-1]", "nodes_of_interest = [11]"), ["run.nodes_of_interest.0 = 11", "[-11, 10]"]),
    (("node = -1", "node = 40"), ["loads.0.node = 40", "node index"]),
    (('kind = "sinusoid"', 'kind = "sine"'), ["loads.0.profile.kind = 'sine'", "'sinusoid'"]),
    ((", frequency = 2.0 }", " }"), ["missing key 'loads.0.profile.frequency'"]),
    (("radius = 0.005", "radius = 0.5"), ["rod: radius=0.5", "smaller than the length"]),
    (('substeps = "auto"', "substeps = 1\nsafety = 0.01"), ["run.substeps = 1", "stable step limit"]),
    (("dt = 1e-3", "dt = -1e-3"), ["run.dt = -0.001", "positive"]),
    (('direction = [1.0, 0.0, 0.0]', 'direction = [0.0, 0.0]'), ["reference.direction", "3-vector"]),
    (("seed = 3", "seed = -3"), ["seed = -3", ">= 0"]),
])
def test_bad_files_give_one_line_errors_naming_file_and_key(tmp_path, change, words):
    old, new = change
    assert old in MINIMAL
    message = _error(tmp_path, MINIMAL.replace(old, new, 1))
    for w in words:
        assert w in message, message


@pytest.mark.parametrize("table, words", [
    ('"loads.0.profile.frequncy" = { uniform = [1.0, 2.0] }', ["unknown key 'loads.0.profile.frequncy'"]),
    ('"loads.4.node" = { integers = [1, 2] }', ["randomize: 'loads.4.node'", "list of 1"]),
    ('"rod.radius" = { uniform = [0.01, 0.001] }', ["randomize.rod.radius.uniform", "lo <= hi"]),
    ('"rod.radius" = { gaussian = [0.01, 0.001] }', ["randomize.rod.radius", "one distribution"]),
    ('"rod.radius" = { loguniform = [0.0, 0.001] }', ["randomize.rod.radius.loguniform", "0 < lo"]),
    ('"seed" = { integers = [1, 2] }', ["'seed' cannot be randomised"]),
])
def test_bad_randomize_tables_are_reported_on_load(tmp_path, table, words):
    message = _error(tmp_path, MINIMAL + "[randomize]\n" + table + "\n")
    for w in words:
        assert w in message, message


def test_unknown_scenario_and_missing_file(tmp_path):
    with pytest.raises(SoftrnnInputError, match="scenario='spiral' is invalid: one of ellipse"):
        load_scenario("spiral")
    with pytest.raises(SoftrnnInputError, match="no such file"):
        load_scenario(str(tmp_path / "absent.toml"))
    with pytest.raises(SoftrnnInputError, match="case='spiral'"):
        build_case("spiral")
    with pytest.raises(ScenarioError, match=r"^<string>: malformed TOML"):
        parse_scenario("a = [")
    message = _error(tmp_path, MINIMAL.replace('file', 'x').replace('[reference]\nkind = "straight"',
                                                                    '[reference]\nkind = "polyline"\nfile = "nope.csv"')
                     .replace("direction = [1.0, 0.0, 0.0]\n", "", 1))
    assert "reference.file = 'nope.csv'" in message


# --------------------------------------------------------------------------- new target paths
@pytest.mark.parametrize("make", [
    lambda seed: Figure8Path(center=(0.5, 0.0, 0.0), width=0.2, height=0.1, period=4.0),
    lambda seed: RandomSmoothPath(center=(0.5, 0.0, 0.0), amplitude=0.1, cutoff=0.5, seed=seed),
])
def test_new_paths_are_smooth_at_the_start_and_deterministic(make):
    path = make(7)
    h = 1e-4
    t = np.array([0.0, h, 2 * h])
    p = path(t)
    np.testing.assert_array_equal(p[0], [0.5, 0.0, 0.0])  # starts at the centre
    velocity = (p[1] - p[0]) / h
    assert np.linalg.norm(velocity) < 1e-6  # smoothstep ramp: zero initial speed (and acceleration)
    tt = np.linspace(0.0, 20.0, 20001)
    q = path(tt)
    np.testing.assert_array_equal(q, make(7)(tt))  # the same parameters (and seed): the same path
    assert q.shape == (tt.size, 3) and np.all(q[:, 0] == 0.5)  # in the yz-plane
    assert np.max(np.abs(q[:, 1:])) <= 0.1 + 1e-12
    speed = np.linalg.norm(np.diff(q, axis=0), axis=1) / np.diff(tt)
    assert np.max(np.abs(np.diff(speed))) < 1e-2  # no corners
    assert np.ptp(q[:, 1]) > 0.05 and np.ptp(q[:, 2]) > 0.02  # it goes somewhere


def test_random_paths_depend_on_their_seed_only():
    t = np.linspace(0.0, 10.0, 101)
    a = RandomSmoothPath(center=(0, 0, 0), amplitude=0.1, cutoff=0.5, seed=1)
    assert not np.allclose(a(t), RandomSmoothPath(center=(0, 0, 0), amplitude=0.1, cutoff=0.5, seed=2)(t))
    assert a == RandomSmoothPath(center=(0, 0, 0), amplitude=0.1, cutoff=0.5, seed=1)
    with pytest.raises(SoftrnnInputError, match="RandomSmoothPath.seed"):
        RandomSmoothPath(center=(0, 0, 0), amplitude=0.1, cutoff=0.5, seed=-1)
    with pytest.raises(SoftrnnInputError, match="Figure8Path.width"):
        Figure8Path(center=(0, 0, 0), width=0.0, height=0.1, period=1.0)
