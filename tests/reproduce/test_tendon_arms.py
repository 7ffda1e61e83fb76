"""The whole-manipulator model of a tendon-driven arm driven by its tensions alone
(``softrnn.reproduce.tendons``): a tiny sweep, a few training steps; the result's structure, the
baselines beside the model, that only the actuation channels reach the model, determinism."""

from dataclasses import replace

import numpy as np
import pytest

from softrnn.learned.whole.config import DynamicConfig
from softrnn.reproduce import tendons

SMALL = DynamicConfig(drive="actuation", node_stride=10, width=8, layers=1, unroll=2, batch=4, steps=8)
CASE = "tendon-planar"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One quick tendon-planar case with a small model: (out folder, entry)."""
    out = tmp_path_factory.mktemp("tendons")
    mp = pytest.MonkeyPatch()
    mp.setitem(tendons.CONFIGS, CASE, SMALL)
    mp.setattr(tendons, "QUICK_STEPS", 8)
    mp.setitem(tendons.QUICK_SWEEP, "duration_s", 2.0)
    try:
        yield out, tendons.tendon_step(out, quick=True, cases=(CASE,))[CASE]
    finally:
        mp.undo()


def test_entry_has_the_dynamic_model_keys_baselines_and_goals(run):
    _, e = run
    assert e["drive"] == "actuation" and e["channels"] == ["tendon_right", "tendon_left"]
    for key in tendons.KEYS:
        assert key in e
    assert e["model_dt_s"] == pytest.approx(0.02) and e["predicted_nodes"] == 5
    assert e["heldout"]["variants"] == tendons.QUICK_SWEEP["n_heldout"]
    assert set(e["heldout"]["baselines"]) == {"persistence", "constant_velocity", "linear"}
    assert set(e["horizons"]) == {"10", "100", "1000"}
    assert set(e["horizons"]["10"]) == {"model", "persistence", "constant_velocity", "linear"}
    assert e["horizons"]["10"]["persistence"] > 0
    assert set(e["test_span"]) >= {"model", "persistence", "constant_velocity", "linear"}
    assert set(e["generalisation"]) >= {"model", "persistence", "constant_velocity", "linear"}
    assert "speed_ratio_vs_simulator" not in e["goals"]
    for g in e["goals"].values():
        assert isinstance(g["met"], bool) and "goal" in g
    assert e["goals_met"] == all(g["met"] for g in e["goals"].values())


def test_a_rerun_reads_the_finished_case(run):
    out, e = run
    mp = pytest.MonkeyPatch()
    mp.setitem(tendons.CONFIGS, CASE, SMALL)
    mp.setattr(tendons, "QUICK_STEPS", 8)
    mp.setitem(tendons.QUICK_SWEEP, "duration_s", 2.0)
    try:
        again = tendons.tendon_case(CASE, out, quick=True)
    finally:
        mp.undo()
    assert again["step_s"] == e["step_s"] and again["heldout"] == e["heldout"]


def test_a_finished_arm_leaves_no_training_job_and_an_unfinished_one_is_ready_to_train(run, tmp_path):
    """``training_jobs`` (the trainings ``softrnn reproduce`` runs in the dynamic step's pool): none
    for a finished arm; for a new one, its data sets and sweep made and its split and config."""
    out, _ = run
    mp = pytest.MonkeyPatch()
    mp.setitem(tendons.CONFIGS, CASE, SMALL)
    mp.setattr(tendons, "QUICK_STEPS", 8)
    mp.setitem(tendons.QUICK_SWEEP, "duration_s", 2.0)
    try:
        assert tendons.training_jobs(out, quick=True, cases=(CASE,)) == []
        (job,) = tendons.training_jobs(tmp_path, quick=True, cases=(CASE,))
    finally:
        mp.undo()
    case, folder, split, config = job
    assert (case, folder, config) == (CASE, tmp_path / "tendons" / CASE, replace(SMALL, steps=8))
    assert (tmp_path / "data" / f"{CASE}.h5").is_file() and not (folder / "model").exists()
    assert len(split.heldout) == tendons.QUICK_SWEEP["n_heldout"]


def test_the_model_reads_only_the_tensions(run):
    """Recorded forces and torques replaced by noise (or zeros) change nothing; other tensions do."""
    from softrnn.io import read_dataset
    from softrnn.learned.baselines import free_run
    from softrnn.learned.whole.artifact import load_dynamic

    out, _ = run
    loaded = load_dynamic(out / "tendons" / CASE / "model")
    ds = read_dataset(out / "data" / f"{CASE}.h5")
    rng = np.random.default_rng(0)
    noisy = replace(ds, forces=rng.normal(size=ds.forces.shape), torques=np.zeros_like(ds.torques))
    pulled = replace(ds, actuation=ds.actuation + 3.0)
    enc = loaded.encoding
    a, b, c = (free_run(loaded.engine, t, None, 3, t.n_steps) for t in map(enc.trajectory, (ds, noisy, pulled)))
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


def test_training_is_deterministic(run):
    from softrnn.learned.whole.fit import fit

    out, _ = run
    s = tendons.settings(CASE, quick=True)["sweep"]
    split = tendons.training_split(out, CASE, out / "sweeps" / CASE, s)
    a, b = (fit(split, replace(SMALL, steps=4))[0].net.state_dict() for _ in range(2))
    assert list(a) == list(b)
    for key in a:
        np.testing.assert_array_equal(a[key].numpy(), b[key].numpy())
