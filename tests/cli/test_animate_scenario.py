"""softrnn animate SCENARIO: one command simulates a scenario (a shipped name or a .toml file) and
animates it, leaving no temporary dataset behind unless --save-data keeps it; a name that is
neither a dataset nor a scenario is a one-line error (exit 2) that writes nothing; the
scenario-only options are refused with a dataset."""

import tempfile

import numpy as np
import pytest
from PIL import Image

from softrnn.io.reader import read_dataset
from softrnn.scenarios.scenario import scenario_text

from helpers import run_cli

SHORT = ["--samples", "3", "--dt", "0.01", "--size", "160x140", "--quiet"]  # 0.02 s of the push


@pytest.fixture
def scratch(tmp_path, monkeypatch):
    """The folder the temporary datasets go to (it must be empty afterwards)."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


def test_a_shipped_scenario_in_one_command(tmp_path, scratch, capsys):
    out = tmp_path / "wire.gif"
    assert run_cli(["animate", "vessel-guidewire", "-o", str(out), *SHORT]) == 0
    printed = capsys.readouterr().out
    assert "simulated vessel-guidewire" in printed and f"wrote {out}" in printed
    with Image.open(out) as im:
        assert im.n_frames == 3 and im.size == (160, 140)
        rgb = np.asarray(im.convert("RGB"), dtype=int)
    assert np.all(rgb[..., 0] == rgb[..., 2])  # the fluoroscopy look (greys) for a vessel, by default
    assert list(scratch.iterdir()) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tmp", "wire.gif"]


def test_a_scenario_file_and_save_data(tmp_path, scratch, monkeypatch, capsys):
    toml = tmp_path / "my-wire.toml"
    toml.write_text(scenario_text("vessel-guidewire"), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    kept = tmp_path / "run.h5"
    assert run_cli(["animate", str(toml), "--save-data", str(kept), "--style", "plain", *SHORT]) == 0
    assert f"saved in {kept}" in capsys.readouterr().out
    assert (tmp_path / "my-wire.gif").is_file() and list(scratch.iterdir()) == []
    data = read_dataset(kept)
    assert data.positions.shape[:2] == (3, 31) and data.attrs["contact"]["obstacles"][0]["kind"] == "vessel"
    with Image.open(tmp_path / "my-wire.gif") as im:
        rgb = np.asarray(im.convert("RGB"), dtype=int)
    assert np.any(rgb[..., 0] != rgb[..., 2])  # the plain look: coloured
    # and the saved dataset animates as a dataset
    assert run_cli(["animate", str(kept), "-o", str(tmp_path / "again.gif"), "--frames", "2", "--quiet"]) == 0


@pytest.mark.parametrize("argv, words", [
    (["animate", "no-such-scenario"], ["data or scenario='no-such-scenario'", "vessel-guidewire", ".toml"]),
    (["animate", "{tmp}/missing.toml"], ["missing.toml", "an existing scenario .toml file"]),
    (["animate", "vessel-guidewire", "--samples", "0"], ["--samples=0"]),
    (["animate", "vessel-guidewire", "--save-data", "{tmp}/run.csv"], ["--save-data", ".h5"]),
    (["animate", "vessel-guidewire", "--style", "xray"], ["--style", "fluoroscopy"]),
])
def test_bad_scenario_is_one_line_and_writes_nothing(argv, words, tmp_path, scratch, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    argv = [a.format(tmp=tmp_path) for a in argv]
    assert run_cli([*argv, "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and all(w in err for w in words), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tmp"] and list(scratch.iterdir()) == []


def test_scenario_options_are_refused_with_a_dataset(tmp_path, capsys):
    h5 = tmp_path / "d.h5"
    h5.write_bytes(b"")
    assert run_cli(["animate", str(h5), "--samples", "3", "-o", str(tmp_path / "d.gif")]) == 2
    err = capsys.readouterr().err
    assert "--samples=3" in err and "only with a scenario" in err and not (tmp_path / "d.gif").exists()


def test_a_prediction_is_drawn_in_the_obstacles_of_its_datas_scenario(tmp_path):
    """A rollout records no contact but keeps its data's scenario (and a sweep variant's draws):
    animate draws that scenario's obstacles, in the variant's geometry, and the fluoroscopy look."""
    import json
    from argparse import Namespace

    from softrnn.cli._animate import _obstacles
    from softrnn.io import Dataset, write_dataset
    from softrnn.rod import Vessel

    text = scenario_text("vessel-guidewire")
    T, N = 3, 31
    p = np.zeros((T, N, 3))
    p[:, :, 0] = np.linspace(-0.32, -0.02, N)
    p[:, :, 2] = -0.00255
    q = np.zeros((T, N, 4))
    q[..., 0] = 1.0
    attrs = {"dt": 0.02, "rod": {"length": 0.3, "radius": 0.00045}, "scenario_text": text, "prediction": True,
             "sampled": json.dumps({"contact.friction": 0.15})}
    data = Dataset(time=np.arange(T) * 0.02, nodes=np.arange(N), positions=p, quaternions=q,
                   forces=np.zeros((T, N, 3)), torques=np.zeros((T, N, 3)), attrs=attrs)
    args = Namespace(no_obstacles=False)
    contact = _obstacles(args, data)
    assert isinstance(contact.obstacles[0], Vessel) and contact.friction == 0.15
    assert _obstacles(Namespace(no_obstacles=True), data) is False
    recorded = Dataset(time=data.time, nodes=data.nodes, positions=p, quaternions=q, forces=data.forces,
                       torques=data.torques, attrs={**attrs, "prediction": False})
    assert _obstacles(args, recorded) is True          # a simulated run: its own record (none here)
    path = tmp_path / "pred.h5"
    write_dataset(path, data)
    out = tmp_path / "pred.gif"
    assert run_cli(["animate", str(path), "-o", str(out), "--size", "160x140", "--quiet"]) == 0
    with Image.open(out) as im:
        rgb = np.asarray(im.convert("RGB"), dtype=int)
    assert np.all(rgb[..., 0] == rgb[..., 2])          # the fluoroscopy look: the vessel was found
