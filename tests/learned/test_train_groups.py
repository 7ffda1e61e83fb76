"""``softrnn train`` on a merged sweep file: ``--group`` picks the trajectory (the same weights as
training on that trajectory's own file), a file of several groups without it is refused in one line
that lists them, and ``--validate-on`` follows the same rule with ``--validate-group``."""

import json

import pytest
import torch

from softrnn.io import write_trajectory
from softrnn.io.sweepfiles import merge_files
from softrnn.learned.node.artifact import load_model

from helpers import run_cli
from helpers import swinging_rod as synthetic

TINY = ["--node", "2", "--epochs", "2", "--units", "8", "--dense", "8", "--batch-size", "64", "--quiet",
        "--rollout-steps", "1"]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Two variants as files (traj-00000.h5, traj-00001.h5) and merged into one sweep file."""
    folder = tmp_path_factory.mktemp("sweep")
    parts = []
    for i, freqs in enumerate([(1.0, 2.3, 1.7, 0.7), (1.3, 2.0, 1.1, 0.9)]):
        path = folder / f"traj-{i:05d}.h5"
        write_trajectory(path, synthetic(200, freqs=freqs), dt=0.01, attrs={"scenario_name": "synthetic"})
        parts.append(path)
    merged = folder / "merged.h5"
    merge_files(parts, merged)
    return parts, merged


def _one_line_error(capsys, *words) -> str:
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error:") and "\n" not in err, err
    assert all(w in err for w in words), err
    return err


def test_a_group_of_a_merged_file_trains_as_its_own_file(files, tmp_path, capsys):
    parts, merged = files
    assert run_cli(["train", str(parts[1]), "-o", str(tmp_path / "file")] + TINY) == 0
    assert run_cli(["train", str(merged), "--group", "traj-00001", "-o", str(tmp_path / "group")] + TINY) == 0
    a, b = load_model(tmp_path / "file"), load_model(tmp_path / "group")
    sa, sb = a.module.state_dict(), b.module.state_dict()
    assert sa.keys() == sb.keys() and all(torch.equal(sa[k], sb[k]) for k in sa)
    strip = [[{k: v for k, v in h.items() if k != "seconds"} for h in m.meta["history"]] for m in (a, b)]
    assert strip[0] == strip[1]
    assert b.meta["dataset"]["group"] == "traj-00001" and "group" not in a.meta["dataset"]
    assert "group" not in json.loads((tmp_path / "file" / "meta.json").read_text())["dataset"]


def test_a_merged_file_of_several_groups_needs_group(files, tmp_path, capsys):
    _, merged = files
    out = tmp_path / "m"
    assert run_cli(["train", str(merged), "-o", str(out)] + TINY) == 2
    _one_line_error(capsys, "--group", "traj-00000, traj-00001", "pass --group NAME")
    assert not out.exists()
    assert run_cli(["train", str(merged), "--group", "traj-00007", "-o", str(out)] + TINY) == 2
    _one_line_error(capsys, "traj-00007", "traj-00000")
    assert not out.exists()


def test_validate_on_a_merged_file_needs_validate_group(files, tmp_path, capsys):
    parts, merged = files
    out = tmp_path / "m"
    base = ["train", str(parts[0]), "-o", str(out), "--validate-on", str(merged)] + TINY
    assert run_cli(base) == 2
    _one_line_error(capsys, "--validate-group", "traj-00000, traj-00001", "pass --validate-group NAME")
    assert not out.exists()
    assert run_cli(base + ["--validate-group", "traj-00001"]) == 0
    val = load_model(out).meta["training_data"]["validation"]
    assert val["file"] == "merged.h5" and val["group"] == "traj-00001"
