"""Magnetic scenarios (a ``[magnetic]`` table): the shipped magnetic-bifurcation steers the
manipulator's tip into the left branch and inserts the rod 12 mm, exactly as ``navigate("left")``
with ``DEMO_ADVANCE``; the opposite field steers it into the right; malformed or forbidden keys
are one-line errors naming the key; softrnn simulate, show, scenario show and sweep run it."""

import dataclasses
import json

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import read_dataset
from softrnn.magnetics.navigation import DEMO_ADVANCE, navigate, navigation_spec, tip_branch
from softrnn.scenarios import ScenarioError, load_scenario, parse_scenario, scenario_text
from softrnn.scenarios.magnetic import bifurcation_of, simulate_magnetic, write_manipulator_dataset

from helpers import run_cli, without_record_builder

NAME = "magnetic-bifurcation"


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(NAME)


@pytest.fixture(scope="module")
def left_run(scenario):
    return simulate_magnetic(scenario.magnetic, scenario.config)


def test_the_shipped_scenario_steers_into_the_left_branch_exactly_as_navigate(scenario, left_run):
    bif = bifurcation_of(scenario.magnetic.spec)
    assert tip_branch(bif, left_run.positions[-1, -1]) == "left"
    assert scenario.magnetic.spec.advance == DEMO_ADVANCE
    # the demo's values: 15 mT, ramp 0.5 s, hold 0.7 s, settle 0.3 s, the base advanced 12 mm
    reference = navigate("left", spec=navigation_spec(advance=DEMO_ADVANCE), hold=0.7)
    np.testing.assert_array_equal(left_run.positions, reference.positions)
    np.testing.assert_array_equal(left_run.quaternions, reference.quaternions)
    np.testing.assert_array_equal(left_run.currents, reference.currents)
    assert scenario.setup.contact is scenario.magnetic.spec.contact and scenario.setup.rod.n_nodes == 26


def test_the_opposite_field_steers_into_the_right_branch(scenario):
    right = scenario.with_values({"magnetic.field_mT.1": -15.0})
    traj = simulate_magnetic(right.magnetic, right.config)
    assert tip_branch(bifurcation_of(right.magnetic.spec), traj.positions[-1, -1]) == "right"
    np.testing.assert_allclose(right.magnetic.currents, -scenario.magnetic.currents, atol=1e-12)


def test_variants_pick_the_branch_and_the_friction(scenario):
    sampled = [scenario.variant(i).sampled for i in range(8)]
    assert {s["magnetic.field_mT.1"] for s in sampled} == {15.0, -15.0}
    assert all(0.05 <= s["contact.friction"] <= 0.2 for s in sampled)
    v = scenario.variant(0)
    assert v.magnetic.spec.contact.friction == v.sampled["contact.friction"]


def _text(old: str, new: str) -> str:
    text = scenario_text(NAME)
    assert old in text
    return text.replace(old, new, 1)


FIELD = "field_mT = [0.0, 15.0, 0.0]"
BAD = [
    (_text("\n[magnetic]\n", "\n[rod]\nlength = 0.05\n\n[magnetic]\n"), "rod", "builds its own rod"),
    (_text("\n[magnetic]\n", "\n[[boundary]]\nkind = \"clamp\"\nnode = 0\n\n[magnetic]\n"), "boundary", "clamped"),
    (_text("\n[magnetic]\n", "\n[[loads]]\nkind = \"force\"\nnode = 0\n\n[magnetic]\n"), "loads", "coils drive"),
    (_text("\n[magnetic]\n", "\n[reference]\nkind = \"straight\"\n\n[magnetic]\n"), "reference", "straight"),
    (_text("\n[magnetic]\n", "\n[initial]\nfrom = \"static\"\n\n[magnetic]\n"), "initial", "settles"),
    (_text("\n[magnetic]\n", "\n[tendons]\n\n[magnetic]\n"), "tendons", "no tendons"),
    (_text(FIELD, "field_mT = [0.0, 15.0]"), "magnetic.field_mT", "expected"),
    (_text(FIELD, "field_mT = [0.0, 500.0, 0.0]"), "magnetic.field_mT", "coil limit"),
    (_text(FIELD, "currents = [1.0, 2.0]"), "magnetic.currents", "6 currents in A"),
    (_text(FIELD, FIELD + "\ncurrents = [0, 0, 0, 0, 0, 0]"), "magnetic.field_mT", "exactly one"),
    (_text("ramp = 0.5 ", "ramp = 0.0 "), "magnetic.ramp", "expected"),
    (_text("settle = 0.3 ", "settle = -1.0 "), "magnetic.settle", "expected"),
    (_text(FIELD, FIELD + "\nbase = [-0.025, 0.0]"), "magnetic.base", "expected"),
    (_text(FIELD, FIELD + "\nlength = 0.5"), "magnetic", "workspace"),
    (_text(FIELD, FIELD + "\nmagnets = 2"), "magnetic.magnets", "unknown key"),
    (_text("distance = 0.012", "distance = -0.012"), "magnetic.advance.distance", "positive number in m"),
    (_text("start = 0.3,", "start = -0.3,"), "magnetic.advance.start", "a number >= 0 in s"),
    (_text("ramp = 0.7 }", "ramp = 0 }"), "magnetic.advance.ramp", "positive number in s"),
    (_text("ramp = 0.7 }", "ramp = 0.7, speed = 1 }"), "magnetic.advance.speed", "unknown key"),
    (_text("distance = 0.012", "distance = 0.2"), "magnetic.advance", "when fully advanced"),
    (_text("advance = { distance = 0.012, start = 0.3, ramp = 0.7 }", "advance = 0.012"), "magnetic.advance",
     "a table"),
    (_text("nodes_of_interest", "save_nodes = [0, 25]\nnodes_of_interest"), "run.save_nodes", "every node"),
    (_text("gravity = [0.0, 0.0, -9.81]", "gravity = { kind = \"constant\", value = [0.0, 0.0, -9.81] }"),
     "gravity", "constant"),
]


@pytest.mark.parametrize("text, key, words", BAD, ids=[f"{i}-{b[1]}" for i, b in enumerate(BAD)])
def test_malformed_or_forbidden_keys_are_one_line_errors_naming_the_key(text, key, words):
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "m.toml")
    message = str(info.value)
    assert "\n" not in message and message.startswith("m.toml: ") and key in message and words in message, message
    assert info.value.key == key


def test_calibrate_refuses_a_magnetic_scenario_in_one_line(scenario):
    from softrnn.calibration.scenario import prepare
    from softrnn.errors import SoftrnnInputError

    with pytest.raises(SoftrnnInputError, match="^scenario='magnetic-bifurcation' is invalid: a plain rod") as info:
        prepare(scenario, None, ["contact.friction"])
    assert "\n" not in str(info.value)


def test_simulate_writes_a_dataset_that_show_reads(left_run, tmp_path, capsys):
    out = tmp_path / "x.h5"
    assert run_cli(["simulate", NAME, "-o", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "tip in: left" in text and "coil currents [A]" in text
    ds = read_dataset(out)
    assert ds.n_samples == 121 and ds.positions.shape == (121, 26, 3) and ds.has_contact
    assert list(ds.actuation_units) == [f"coil_{k}" for k in range(6)]
    assert ds.attrs["tip_branch"] == "left" and ds.attrs["scenario_name"] == NAME
    record = ds.record                      # what drove it: the advancing base is a moving clamp
    assert record.to_record() == json.loads(json.dumps(load_scenario(NAME).record.to_record()))
    assert record.name == NAME and record.nodes_of_interest == (25,) and record.moving_clamps == (0,)
    assert record.paper["role"] == "training" and record.contact is not None and record.variant_index is None
    np.testing.assert_array_equal(ds.positions, left_run.positions.astype(np.float32))   # stored as float32
    assert run_cli(["show", str(out)]) == 0
    assert run_cli(["simulate", NAME, "--radius", "0.002", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--radius" in err and "magnetic scenario" in err


def test_scenario_show_summary(capsys):
    assert run_cli(["scenario", "show", NAME, "--summary"]) == 0
    text = capsys.readouterr().out
    assert "bifurcation" in text and "coils: field [0, 15, 0] mT at the centre" in text
    assert "magnets N42 at 25 mm, N45 at 49 mm" in text


def test_a_sweep_of_two_variants(tmp_path, capsys):
    out = tmp_path / "sweep"
    assert run_cli(["sweep", NAME, "--count", "2", "-o", str(out), "--samples", "11", "--workers", "1",
                    "--quiet"]) == 0
    manifest = json.loads((out / "sweep.json").read_text())
    assert manifest["n_samples"] == 11
    for i in range(2):
        ds = read_dataset(out / f"traj-{i:05d}.h5")
        assert ds.n_samples == 11 and ds.positions.shape[1] == 26 and len(ds.actuation_units) == 6
        assert json.loads(ds.attrs["sampled"]) == load_scenario(NAME).variant(i).sampled
        assert ds.record.variant_index == i and ds.record.sampled == json.loads(ds.attrs["sampled"])
        assert ds.record.moving_clamps == (0,) and ds.record.name == NAME
        assert ds.record.contact.friction == ds.record.sampled["contact.friction"]


ADVANCE = "advance = { distance = 0.012, start = 0.3, ramp = 0.7 }"


def test_the_record_holds_the_advancing_base_as_a_moving_clamp_and_a_fixed_base_as_none(scenario):
    assert scenario.record.moving_clamps == (0,) and scenario.record.pd == ()
    fixed = parse_scenario(_text(ADVANCE, ""), "m.toml")
    assert fixed.magnetic.spec.advance is None and fixed.record.moving_clamps == ()


@pytest.mark.slow
def test_the_implicit_integrator_runs_it_and_agrees_with_the_explicit_within_its_own_error(scenario, tmp_path,
                                                                                            capsys):
    """Settling, the ramp and the start of the advance (0.3 s) with both integrators: the implicit
    step (first order, its step 3x the explicit one) differs from the explicit run by at most its
    own error, estimated as twice the change of its run when its step is halved (4.7e-5 m against
    2 x 3.6e-5 m), and the halved step comes closer to the explicit run. Slow: most of its minute compiles
    the implicit kernel with magnets and contact together; each with the implicit integrator is tested apart
    (tests/magnetics/test_magnetic_load.py, tests/rod/test_contact_predictive.py)."""
    config = dataclasses.replace(scenario.config, n_samples=31)
    explicit = simulate_magnetic(scenario.magnetic, config)
    implicit_text = _text("nodes_of_interest", "integrator = \"implicit\"\nnodes_of_interest")
    from_text = parse_scenario(implicit_text, "m.toml")
    assert from_text.config.integrator.name == "implicit"
    implicit = simulate_magnetic(from_text.magnetic, dataclasses.replace(from_text.config, n_samples=31))
    finer = simulate_magnetic(scenario.magnetic, dataclasses.replace(config, integrator="implicit",
                                                                     substeps=2 * implicit.substeps))
    assert implicit.step > explicit.step
    gap = np.abs(implicit.positions - explicit.positions).max()
    own = np.abs(implicit.positions - finer.positions).max()
    assert gap <= 2 * own and np.abs(finer.positions - explicit.positions).max() < gap and gap < 1e-4
    path = tmp_path / "implicit.toml"
    path.write_text(implicit_text)
    assert run_cli(["scenario", "show", str(path), "--summary"]) == 0
    assert "implicit integrator" in capsys.readouterr().out
    assert run_cli(["simulate", NAME, "--integrator", "implicit", "--samples", "3", "--quiet"]) == 0
    assert "implicit solver step" in capsys.readouterr().out


def test_the_whole_model_takes_the_advancing_base_as_a_path_input(scenario, left_run, tmp_path):
    """A whole-manipulator model of magnetic data with an advance: node 0 (the moved base) is a
    prescribed input, from the stored record or, for a file without it, from its scenario text."""
    pytest.importorskip("torch")
    from softrnn.learned.whole import training
    from softrnn.learned.whole.config import DynamicConfig
    from softrnn.learned.whole.encoding import make_encoding
    from softrnn.learned.whole.feedback import moving_clamps

    path = tmp_path / "m.h5"
    write_manipulator_dataset(path, left_run, scenario.magnetic.spec, dt=scenario.config.dt,
                              scenario_text=scenario.text, record=scenario.record)
    data = read_dataset(path)
    old = dataclasses.replace(data, attrs={k: v for k, v in data.attrs.items() if k != "scenario_record"})
    assert moving_clamps(data) == moving_clamps(old) == (0,)
    with without_record_builder(), pytest.raises(SoftrnnInputError, match="with_record"):
        moving_clamps(old)
    config = DynamicConfig(model_dt=0.02, node_stride=5, steps=2, unroll=2, batch=4, width=8, layers=1)
    enc = make_encoding([data], model_dt=0.02, node_stride=5, length=scenario.magnetic.spec.length, prescribed=True)
    assert enc.prescribed[list(enc.kept).index(0)] and enc.prescribed.sum() == 1
    result = training.train_dynamic_model([enc.trajectory(data)], enc, config, threads=1)
    assert result.encoding.prescribed.sum() == 1 and np.isfinite(result.info["final_loss"])
