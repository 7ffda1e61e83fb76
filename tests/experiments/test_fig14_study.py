"""The Fig. 14 study: every grid point's results, resume after an interruption (only the missing points
are computed), refused settings, bad grids, the figure, Dask = in-process, and ``softrnn study hparams``."""

import json
import os
import shutil

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.experiments.fig14 import (
    FIGURE,
    MANIFEST,
    StudyConfig,
    model_folder,
    point_path,
    run_study,
    summary,
)
from softrnn.experiments.fig14_config import PAPER_FIG14
from softrnn.experiments.fig14_summary import region
from softrnn.io import write_trajectory
from softrnn.learned.node.artifact import load_model
from softrnn.learned.node.evaluate import evaluate
from softrnn.learned.node.train import TrainConfig

from helpers import run_cli
from helpers import swinging_rod as synthetic

SYNC = "synchronous"
TINY = {"node": 2, "units": (4, 8), "history": (2, 3), "epochs": 2, "bandwidth_steps": 50, "torch_steps": 5}
CONFIG = StudyConfig(**TINY)


class _Interrupt:
    """progress callback raising KeyboardInterrupt once ``after`` steps are done."""

    def __init__(self, after):
        self.after = after

    def __call__(self, done, total, info=None):
        if done >= self.after:
            raise KeyboardInterrupt


def _mtimes(paths) -> dict:
    return {str(p): p.stat().st_mtime_ns for p in paths}


@pytest.fixture(scope="module")
def data_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "synthetic.h5"
    write_trajectory(path, synthetic(300), dt=0.01, attrs={"scenario_name": "synthetic"})
    return path


@pytest.fixture(scope="module")
def full(data_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("study-full")
    return out, run_study(data_file, CONFIG, out, scheduler=SYNC)


def _rmse(result) -> dict:
    return {(r["units"], r["history"]): r["error"]["rmse_mm"] for r in result.points}


# ------------------------------------------------------------------------------------------ results
def test_every_grid_point_has_errors_bandwidths_and_a_model(full):
    out, result = full
    assert sorted(result.computed) == [[4, 2], [4, 3], [8, 2], [8, 3]] and result.found == []
    assert len(result.points) == 4
    for r in result.points:
        e, b = r["error"], r["bandwidth"]
        assert e["rmse_mm"] > 0 and e["n_targets"] == 120 - r["history"]
        # overall RMSE (paper Eq. 2 over every target) = root mean of the per-axis mean squares
        assert e["rmse_mm"] == pytest.approx(np.sqrt(np.mean(np.square(e["rmse_axis_mm"]))), rel=1e-12)
        assert b["stepper"]["hz"] > 0 and b["stepper"]["calls"] == 50 and b["torch"]["calls"] == 5
        assert b["stepper"]["hz"] == pytest.approx(1e6 / b["stepper"]["median_us"])
        on_disk = json.loads(point_path(out, r["units"], r["history"]).read_text())
        assert on_disk == json.loads(json.dumps(r))
        model = load_model(model_folder(out, r["units"], r["history"]))
        assert (model.config.lstm_units, model.spec.history) == (r["units"], r["history"])
    table = np.array(result.rmse_mm)                                     # (history, units)
    assert table.shape == (2, 2) and table[1, 0] == _rmse(result)[(4, 3)]
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["config"] == CONFIG.to_dict() and len(manifest["data"]["sha256"]) == 64


def test_the_point_errors_are_those_of_softrnn_evaluate(full, data_file):
    out, result = full
    r = result.points[3]
    ev = evaluate(load_model(model_folder(out, r["units"], r["history"])), data_file, free=False)
    assert r["error"]["rmse_mm"] == pytest.approx(ev.one_step_errors.rmse_mm, rel=1e-12)
    assert r["error"]["max_abs_mm"] == pytest.approx(list(ev.one_step_errors.max_abs_mm), rel=1e-12)


def test_the_figure_is_a_png(full):
    out, result = full
    assert result.figure == str(out / FIGURE)
    assert (out / FIGURE).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(out.glob(".*tmp*"))


def test_regions_and_paper_statements():
    config = StudyConfig(node=0, units=(5, 10, 20), history=(2, 10))
    bw = np.array([[100.0, 95.0, 80.0], [50.0, 40.0, 30.0]])                # rows: history, columns: units
    reg = region(config, bw, maximise=True)
    assert reg.best == {"units": 5, "history": 2, "value": 100.0}
    assert reg.points == [[5, 2], [10, 2]] and reg.units == [5, 10] and reg.history == [2, 2]
    err = region(config, np.array([[3.0, 2.0, 1.05], [3.0, 2.0, 1.0]]), maximise=False)
    assert err.points == [[20, 2], [20, 10]]
    records = [{"units": u, "history": h, "error": {"rmse_mm": 1.0 / u},
                "bandwidth": {"stepper": {"hz": 100.0 / h}, "torch": None}} for h in (2, 10) for u in (5, 10, 20)]
    s = summary(config, records)
    assert s.regions["rms_error"].points == [[20, 2], [20, 10]]
    assert s.regions["rms_error"].fraction_in_paper_region == 1.0    # units 20, H 2-10: in (20, 25) x (2, 20)
    assert s.regions["bandwidth"].fraction_in_paper_region == pytest.approx(2 / 3)
    assert s.trends["bandwidth_vs_history"] == pytest.approx(-0.8) and s.trends["bandwidth_vs_units"] == 0.0
    assert s.regions["torch_bandwidth"] is None
    assert "(5, 15)" in s.paper["bandwidth"] and "(20, 25)" in s.paper["rms_error"]
    assert PAPER_FIG14["bandwidth_region"] == {"history": [2, 20], "lstm_units": [5, 15]}


# ------------------------------------------------------------------------------------------ resume
def test_an_interrupted_study_computes_only_the_missing_points(full, data_file, tmp_path):
    with pytest.raises(KeyboardInterrupt):
        run_study(data_file, CONFIG, tmp_path, scheduler=SYNC, progress=_Interrupt(2))   # 2 points trained
    done = sorted(p.name for p in tmp_path.glob("point-*.json"))
    assert done == ["point-u04-h02.json", "point-u08-h02.json"]
    weights = _mtimes(model_folder(tmp_path, u, 2) / "weights.safetensors" for u in (4, 8))
    result = run_study(data_file, CONFIG, tmp_path, scheduler=SYNC)
    assert result.computed == [[4, 3], [8, 3]] and result.found == []
    assert result.measured == [[4, 2], [4, 3], [8, 2], [8, 3]]          # the first run timed none
    assert _mtimes(model_folder(tmp_path, u, 2) / "weights.safetensors" for u in (4, 8)) == weights
    assert _rmse(result) == _rmse(full[1])                                # = the uninterrupted study


def test_a_deleted_point_is_the_only_one_computed_again(full, data_file, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(full[0], out)
    point_path(out, 8, 3).unlink()
    shutil.rmtree(model_folder(out, 8, 3))
    kept = _mtimes(point_path(out, u, h) for u, h in CONFIG.points if (u, h) != (8, 3))
    result = run_study(data_file, CONFIG, out, scheduler=SYNC)
    assert result.computed == [[8, 3]] and result.measured == [[8, 3]]
    assert result.found == [[4, 2], [4, 3], [8, 2]]
    assert _mtimes(point_path(out, u, h) for u, h in CONFIG.points if (u, h) != (8, 3)) == kept
    assert _rmse(result) == _rmse(full[1])


def test_the_grid_may_shrink_and_nothing_is_recomputed(full, data_file):
    out, _ = full
    result = run_study(data_file, StudyConfig(**dict(TINY, units=(8,), history=(2,))), out, scheduler=SYNC)
    assert result.computed == [] and result.measured == [] and result.found == [[8, 2]]
    assert result.rmse_mm == [[_rmse(full[1])[(8, 2)]]]


# ------------------------------------------------------------------------------------------ refusals
def test_other_settings_or_data_in_the_same_folder_are_refused(full, data_file, tmp_path):
    out, _ = full
    with pytest.raises(SoftrnnInputError, match=r"epochs: 2 then, 3 now.*use another folder"):
        run_study(data_file, StudyConfig(**dict(TINY, epochs=3)), out, scheduler=SYNC)
    other = tmp_path / "other.h5"
    write_trajectory(other, synthetic(301), dt=0.01)
    with pytest.raises(SoftrnnInputError, match="another data file.*use another folder"):
        run_study(other, CONFIG, out, scheduler=SYNC)


@pytest.mark.parametrize("kwargs, match", [
    ({"units": ()}, r"units=\[\] is invalid"), ({"units": (0, 4)}, "units=.*positive integers"),
    ({"units": (4, 4)}, "units=.*distinct"), ({"units": "4"}, "units='4'"), ({"units": (2.5,)}, "units="),
    ({"history": (0,)}, "history="), ({"epochs": 0}, "epochs=0"), ({"region_tolerance": 1.0}, "region_tolerance"),
    ({"wrench": "torque"}, "wrench='torque'"), ({"train": {"epochs": 3}}, "train=.*TrainConfig"),
    ({"bandwidth_steps": 1}, "bandwidth_steps=1"),
])
def test_bad_study_settings(kwargs, match):
    with pytest.raises(SoftrnnInputError, match=match):
        StudyConfig(**dict(TINY, **kwargs))


def test_the_study_config_sorts_the_grid_and_keeps_other_train_settings():
    c = StudyConfig(node=1, units=(20, 5), history=(10, 2), epochs=4, seed=3, train=TrainConfig(batch_size=32))
    assert c.units == (5, 20) and c.history == (2, 10)
    assert (c.train.epochs, c.train.seed, c.train.batch_size) == (4, 3, 32)
    assert c.points == [(5, 2), (20, 2), (5, 10), (20, 10)]
    n = StudyConfig(node=1, neighbours=[0, 2])
    assert n.neighbours == (0, 2) and n.to_dict()["neighbours"] == [0, 2] and hash(n)


@pytest.mark.parametrize("kwargs, run, match", [
    ({"history": (2, 100)}, {}, r"history=\[2, 100\] is invalid.*300 samples"),
    ({"node": 7}, {}, "node=7 is invalid.*0..4"),
    ({}, {"workers": 0}, "--workers=0"),
    ({}, {"scheduler": ""}, "--scheduler"),
])
def test_bad_runs_fail_before_any_training(data_file, tmp_path, kwargs, run, match):
    with pytest.raises(SoftrnnInputError, match=match):
        run_study(data_file, StudyConfig(**dict(TINY, **kwargs)), tmp_path / "s", **dict({"scheduler": SYNC}, **run))
    assert not (tmp_path / "s" / "models").exists()


def test_a_missing_data_file_is_one_line(tmp_path):
    with pytest.raises(SoftrnnInputError, match="data=.*existing softrnn HDF5"):
        run_study(tmp_path / "none.h5", CONFIG, tmp_path / "s", scheduler=SYNC)


# ------------------------------------------------------------------------------------------ Dask
def test_a_local_dask_cluster_gives_the_in_process_results(full, data_file, tmp_path):
    config = StudyConfig(**dict(TINY, units=(4,), torch_steps=0))
    environ = dict(os.environ)
    result = run_study(data_file, config, tmp_path, workers=1)
    assert dict(os.environ) == environ   # worker settings never leak into the calling process
    assert result.computed == [[4, 2], [4, 3]]
    assert {p: v for p, v in _rmse(result).items()} == {p: v for p, v in _rmse(full[1]).items() if p[0] == 4}
    assert all(r["bandwidth"]["torch"] is None for r in result.points)


# ------------------------------------------------------------------------------------------ CLI
def test_cli_prints_the_table_regions_and_writes_json(data_file, tmp_path, capsys):
    out, js = tmp_path / "study", tmp_path / "s.json"
    argv = ["study", "hparams", str(data_file), "--node", "2", "-o", str(out), "--units", "4", "--history", "2,3",
            "--epochs", "1", "--bandwidth-steps", "20", "--scheduler", SYNC, "--json", str(js), "--quiet"]
    assert run_cli(argv) == 0
    text = capsys.readouterr().out
    assert "2 grid points" in text and "stepper Hz" in text and "RMS error: best" in text
    assert "Figure 14" in text and "(20, 25)" in text and "fig14.png" in text
    summary_json = json.loads(js.read_text())
    assert summary_json["units"] == [4] and len(summary_json["points"]) == 2
    assert run_cli(argv) == 0 and "0 trained, 0 timed now, 2 already there" in capsys.readouterr().out


@pytest.mark.parametrize("extra, words", [
    (["--units", "4,x"], ["--units='4,x' is invalid"]),
    (["--history", "0"], ["history=[0] is invalid"]),
    (["--epochs", "2"], ["epochs: 1 then, 2 now", "another folder"]),
    (["--workers", "0"], ["--workers=0"]),
    (["--wrench", "torque"], ["invalid choice", "softrnn study hparams --help"]),
    (["--nope"], ["unrecognized arguments"]),
])
def test_cli_bad_input_is_one_line_exit_2(data_file, tmp_path, capsys, extra, words):
    out = tmp_path / "study"
    base = ["study", "hparams", str(data_file), "--node", "2", "-o", str(out), "--units", "4", "--history", "2",
            "--epochs", "1", "--bandwidth-steps", "20", "--scheduler", SYNC, "--quiet"]
    if "--epochs" in extra:
        assert run_cli(base) == 0
        capsys.readouterr()
    assert run_cli(base + extra) == 2                                     # argparse keeps the last value
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("softrnn: error:")
    for w in words:
        assert w in err


def test_cli_ctrl_c_keeps_the_finished_points(data_file, tmp_path, capsys, monkeypatch):
    import softrnn.experiments.fig14

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(softrnn.experiments.fig14, "run_study", interrupted)
    argv = ["study", "hparams", str(data_file), "--node", "2", "-o", str(tmp_path), "--quiet"]
    assert run_cli(argv) == 130
    assert "finished grid points are kept" in capsys.readouterr().err
