"""Sweeps on a 2-worker Dask LocalCluster: completion, determinism, resume after interruption."""

import json

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import read_dataset
from softrnn.scenarios.scenario import load_scenario
from softrnn.sweeps.sweep import run_sweep, trajectory_path

SAMPLES = 21  # short trajectories: the test is about the sweep machinery


class _Interrupt:
    """progress callback that raises KeyboardInterrupt once ``after`` trajectories are done."""

    def __init__(self, after):
        self.after = after

    def __call__(self, done, total, info=None):
        if done >= self.after:
            raise KeyboardInterrupt


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("semicircle")


@pytest.fixture(scope="module")
def full_sweep(tmp_path_factory, scenario):
    out = tmp_path_factory.mktemp("sweep-full")
    result = run_sweep(scenario, 32, out, n_workers=2, n_samples=SAMPLES)
    return out, result


def test_32_trajectory_sweep_completes(full_sweep, scenario):
    out, result = full_sweep
    assert result.computed == list(range(32)) and result.skipped == []
    sampled = set()
    for i in range(32):
        ds = read_dataset(trajectory_path(out, i))
        assert ds.positions.shape == (SAMPLES, scenario.setup.rod.n_nodes, 3)
        assert np.all(np.isfinite(ds.positions))
        assert ds.attrs["variant_index"] == i
        sampled.add(ds.attrs["sampled"])
    assert len(sampled) == 32  # every variant drew different values
    manifest = json.loads((out / "sweep.json").read_text())
    assert manifest["scenario"] == "semicircle" and manifest["n_samples"] == SAMPLES


def test_different_variants_differ_same_variant_repeats(full_sweep, scenario, tmp_path):
    out, _ = full_sweep
    a = read_dataset(trajectory_path(out, 3))
    b = read_dataset(trajectory_path(out, 4))
    assert not np.array_equal(a.positions, b.positions)
    again = run_sweep(scenario, 1, tmp_path, n_workers=1, n_samples=SAMPLES)
    assert again.computed == [0]
    np.testing.assert_array_equal(read_dataset(trajectory_path(tmp_path, 0)).positions,
                                  read_dataset(trajectory_path(out, 0)).positions)


def test_interrupted_sweep_resumes_only_missing_and_equals_uninterrupted(full_sweep, scenario, tmp_path):
    out_full, _ = full_sweep
    with pytest.raises(KeyboardInterrupt):
        run_sweep(scenario, 32, tmp_path, n_workers=2, n_samples=SAMPLES, progress=_Interrupt(after=12))
    present = sorted(i for i in range(32) if trajectory_path(tmp_path, i).exists())
    assert 12 <= len(present) < 32
    (tmp_path / "traj-00031.h5.tmp-stale").write_bytes(b"half a file")  # a worker killed mid-write
    resumed = run_sweep(scenario, 32, tmp_path, n_workers=2, n_samples=SAMPLES)
    assert resumed.skipped == present
    assert resumed.computed == sorted(set(range(32)) - set(present))
    assert not list(tmp_path.glob("*.tmp*"))
    for i in range(32):
        x = read_dataset(trajectory_path(tmp_path, i))
        y = read_dataset(trajectory_path(out_full, i))
        for name in ("time", "positions", "quaternions", "forces", "torques"):
            np.testing.assert_array_equal(getattr(x, name), getattr(y, name))


def test_folder_of_another_sweep_is_refused(full_sweep, scenario):
    out, _ = full_sweep
    with pytest.raises(SoftrnnInputError, match="another"):
        run_sweep(scenario, 4, out, n_workers=1, n_samples=SAMPLES + 1)


def test_bad_sweep_arguments(scenario, tmp_path):
    with pytest.raises(SoftrnnInputError, match="--count=0"):
        run_sweep(scenario, 0, tmp_path)
    with pytest.raises(SoftrnnInputError, match="--workers=0"):
        run_sweep(scenario, 2, tmp_path, n_workers=0)
    assert list(tmp_path.iterdir()) == []


def test_cli_sweep_resumes_and_merges(full_sweep, tmp_path, capsys):
    from softrnn.cli.main import main
    from softrnn.io import list_groups

    out, _ = full_sweep
    merged = tmp_path / "all.h5"
    assert main(["sweep", "semicircle", "--count", "32", "-o", str(out), "--samples", str(SAMPLES),
                 "--merge", str(merged), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "0 computed" in text and "32 already there" in text
    assert len(list_groups(merged)) == 32
    np.testing.assert_array_equal(read_dataset(merged, group=list_groups(merged)[5]).positions,
                                  read_dataset(trajectory_path(out, 5)).positions)


def test_sweep_with_a_coarser_saved_interval_is_recorded_and_kept(scenario, tmp_path, capsys):
    from softrnn.cli.main import main

    result = run_sweep(scenario, 1, tmp_path, n_workers=1, n_samples=4, dt=0.01)
    assert result.computed == [0]
    ds = read_dataset(trajectory_path(tmp_path, 0))
    assert ds.dt == 0.01 and ds.n_samples == 4
    np.testing.assert_allclose(np.diff(ds.time), 0.01, rtol=1e-9)
    assert json.loads((tmp_path / "sweep.json").read_text())["dt"] == 0.01
    assert run_sweep(scenario, 1, tmp_path, n_workers=1, n_samples=4, dt=0.01).skipped == [0]
    for other in (0.02, None):                          # another interval, or the scenario's own
        with pytest.raises(SoftrnnInputError, match="dt: 0.01 !="):
            run_sweep(scenario, 1, tmp_path, n_workers=1, n_samples=4, dt=other)
    assert main(["sweep", "semicircle", "--count", "1", "-o", str(tmp_path), "--samples", "4", "--dt", "0.02",
                 "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "dt: 0.01 != 0.02" in err


@pytest.mark.parametrize("dt", [0, -0.01, float("nan"), "0.01"])
def test_bad_saved_interval_is_refused_before_anything_is_written(scenario, tmp_path, dt):
    with pytest.raises(SoftrnnInputError, match="--dt=.* is invalid: a positive"):
        run_sweep(scenario, 2, tmp_path, n_workers=1, dt=dt)
    assert list(tmp_path.iterdir()) == []


def test_an_absurd_saved_interval_is_refused_before_any_worker_starts(scenario, tmp_path):
    with pytest.raises(SoftrnnInputError, match="dt=1e\\+09 s is too large"):
        run_sweep(scenario, 1, tmp_path, n_workers=1, n_samples=3, dt=1e9)
    assert list(tmp_path.iterdir()) == []
