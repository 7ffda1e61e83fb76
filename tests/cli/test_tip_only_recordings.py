"""A tip-only recording (an imported lab session) given to ``dynamic train``: refused up front in one
line, exit 2, naming what works on it instead, and nothing written."""

import numpy as np
import pytest

from softrnn.io import Dataset, write_trajectory
from softrnn.learned.whole.data import check_whole_rod

from helpers import run_cli


def recording(path, nodes):
    """A short recording of ``nodes`` (a tip marker: one node) with two actuation channels."""
    T, n = 40, len(nodes)
    time = np.arange(T) * 0.05
    pos = np.zeros((T, n, 3))
    pos[:, :, 0] = 0.1 * (1 + np.arange(n))
    pos[:, :, 1] = 0.01 * np.sin(time)[:, None]
    quats = np.zeros((T, n, 4))
    quats[..., 0] = 1.0
    ds = Dataset(time=time, nodes=np.asarray(nodes), positions=pos, quaternions=quats, forces=np.zeros_like(pos),
                 torques=np.zeros_like(pos), actuation=np.column_stack([np.sin(time), np.cos(time)]),
                 actuation_units={"tendon_1": "N", "tendon_2": "N"})
    write_trajectory(path, ds, dt=0.05)
    return path


@pytest.mark.parametrize("where", ["DATA", "--validate-on", "sweep folder"])
def test_dynamic_train_refuses_a_tip_only_recording(where, tmp_path, capsys):
    pytest.importorskip("torch")
    tip = recording(tmp_path / "tip.h5", [10])
    whole = recording(tmp_path / "whole.h5", [0, 1, 2, 3])
    out = tmp_path / "model"
    if where == "DATA":
        argv = ["dynamic", "train", str(tip), "-o", str(out), "--quiet"]
    elif where == "--validate-on":
        argv = ["dynamic", "train", str(whole), "--validate-on", str(tip), "-o", str(out), "--quiet"]
    else:
        (tmp_path / "sweep").mkdir()
        recording(tmp_path / "sweep" / "traj-00000.h5", [10])
        argv = ["dynamic", "train", str(tmp_path / "sweep"), "-o", str(out), "--quiet"]
    before = sorted(p.name for p in tmp_path.iterdir())
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for words in ("records one node (node 10)", "several nodes", "softrnn train FILE --drive actuation",
                  "softrnn lab benchmark"):
        assert words in err, err
    assert "kept=" not in err and "pass one of those node indices" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == before          # no model folder


def test_recordings_of_several_nodes_pass_the_check(tmp_path):
    check_whole_rod([recording(tmp_path / "whole.h5", [0, 1, 2]), tmp_path / "missing.h5"])
    check_whole_rod(tmp_path / "whole.h5")
