"""What a lab looks at first: a prediction drawn over its reference data (``plot``/``animate --over``),
the actuation inputs in ``plot`` and ``show``, the only node of a recording chosen by itself, and the
view that shows a rod inside its flat vessel."""

from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from softrnn.errors import SoftrnnInputError
from softrnn.figures import animation, geometry, overlay, pictures
from softrnn.io import Dataset, read_dataset, write_trajectory

from helpers import run_cli

OFFSET = 0.004  # m: the stand-in prediction's error, along y, from its start on


def reference_data(n_samples=41, n_nodes=6):
    """A rod along +x swinging in y and z; 3 actuation channels (two tensions [N], one displacement [mm])."""
    time = np.linspace(0.0, 0.4, n_samples)
    s = np.linspace(0.0, 0.5, n_nodes)
    pos = np.zeros((n_samples, n_nodes, 3))
    pos[:, :, 0] = s
    pos[:, :, 1] = 0.1 * np.sin(2 * np.pi * time)[:, None] * (s / 0.5) ** 2
    pos[:, :, 2] = -0.05 * (1 - np.cos(2 * np.pi * time))[:, None] * (s / 0.5) ** 2
    quats = np.zeros((n_samples, n_nodes, 4))
    quats[..., 0] = 1.0
    act = np.column_stack([np.sin(time), np.cos(time), 10 * time])
    return Dataset(time=time, nodes=np.arange(n_nodes), positions=pos, quaternions=quats,
                   forces=np.zeros_like(pos), torques=np.zeros_like(pos), attrs={"name": "arm"},
                   actuation=act, actuation_units={"tendon_1": "N", "tendon_2": "N", "servo": "mm"})


def prediction_of(ref: Dataset, first: int = 10, offset: float = OFFSET) -> Dataset:
    """The reference's samples from ``first`` on, ``offset`` m off in y after its first 2 (the seed)."""
    pos = np.array(ref.positions[first:])
    pos[2:, :, 1] += offset
    return Dataset(time=ref.time[first:], nodes=ref.nodes, positions=pos, quaternions=ref.quaternions[first:],
                   forces=ref.forces[first:], torques=ref.torques[first:], attrs={"scenario_name": "arm (predicted)"})


@pytest.fixture
def pair(tmp_path):
    ref = reference_data()
    ref_path = tmp_path / "ref.h5"
    write_trajectory(ref_path, ref, dt=0.01)
    pred_path = tmp_path / "pred.h5"
    pred = prediction_of(ref)
    write_trajectory(pred_path, pred, dt=0.01, attrs={
        "scenario_name": "arm (predicted)", "prediction": True, "reference": str(ref_path),
        "predicted_from_s": float(pred.time[2]), "node_of_interest": 5})
    return ref, pred, ref_path, pred_path


# ------------------------------------------------------------------------------------------ overlay
def test_align_matches_the_predicted_samples_and_nodes():
    ref = reference_data()
    pred = prediction_of(ref, first=10)
    rows, cols = overlay.align(pred, ref)
    assert rows.tolist() == list(range(10, 41)) and cols.tolist() == list(range(6))
    every_other = SimpleNamespace(time=ref.time[10::2], nodes=np.array([5, 2]))      # a model step of 2 samples
    rows, cols = overlay.align(every_other, ref)
    assert rows.tolist() == list(range(10, 41, 2)) and cols.tolist() == [5, 2]
    with pytest.raises(SoftrnnInputError, match=r"no sample at t = 0.105 s .*--over"):
        overlay.align(SimpleNamespace(time=ref.time[10:] + 0.005, nodes=ref.nodes), ref)
    with pytest.raises(SoftrnnInputError, match=r"no node 9 .* 0\.\.5"):
        overlay.align(SimpleNamespace(time=ref.time, nodes=np.array([9])), ref)


def test_plot_draws_the_prediction_over_its_reference_with_the_error(pair):
    ref, _, _, pred_path = pair
    pred = read_dataset(pred_path)                       # as written: it records where the prediction starts
    fig = pictures.plot_node(pred, 5, reference=ref, inputs=False)
    axes = fig.get_axes()
    assert [ax.get_ylabel() for ax in axes] == ["x [mm]", "y [mm]", "z [mm]", "|error| [mm]"]
    labels = [line.get_label() for line in axes[1].get_lines()]
    assert labels == ["reference (data)", "prediction"]
    assert axes[1].get_lines()[0].get_linestyle() == "--" and axes[1].get_lines()[1].get_linestyle() == "-"
    error = axes[3].get_lines()[0].get_ydata()
    np.testing.assert_allclose(error[:2], 0.0, atol=1e-6)
    np.testing.assert_allclose(error[2:], OFFSET * 1e3, rtol=1e-4)
    assert "largest 4 mm" in axes[3].get_legend().get_texts()[0].get_text()
    assert axes[3].get_lines()[1].get_xdata()[0] == pytest.approx(pred.time[2])   # where the prediction starts
    assert "over its reference" in axes[0].get_title()


def test_cli_plot_and_animate_over_the_recorded_or_given_reference(pair, tmp_path, capsys, monkeypatch):
    _, _, ref_path, pred_path = pair
    png = tmp_path / "over.png"
    assert run_cli(["plot", str(pred_path), "--over", "-o", str(png)]) == 0        # the recorded reference
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"over {ref_path}" in capsys.readouterr().out
    assert run_cli(["plot", str(pred_path), "-o", str(tmp_path / "alone.png")]) == 0     # a hint where it is useful
    assert f"'softrnn plot {pred_path} --over' draws it over its reference data" in capsys.readouterr().out
    assert run_cli(["plot", str(ref_path), "--node", "2", "-o", str(tmp_path / "ref.png")]) == 0
    assert "--over" not in capsys.readouterr().out
    assert run_cli(["plot", str(pred_path), "--over", str(ref_path), "-o", str(png), "--overwrite",
                    "--node", "3"]) == 0
    seen = []
    real = animation.write_movie
    monkeypatch.setattr(animation, "write_movie", lambda scene, *a, **k: seen.append(scene) or real(scene, *a, **k))
    gif = tmp_path / "over.gif"
    assert run_cli(["animate", str(pred_path), "--over", str(ref_path), "-o", str(gif), "--frames", "3",
                    "--size", "200x160", "--quiet"]) == 0
    with Image.open(gif) as im:
        assert (im.n_frames, im.size) == (3, (200, 160))
    scene = seen[0]
    assert scene.ref in scene.dynamic and scene.ref.get_linestyle() == "--"
    legend = [t.get_text() for t in scene.fig.legends[0].get_texts()]
    assert legend[:2] == ["prediction", "reference (data)"]
    scene.update(len(scene.time) - 1)
    assert "tip (node 5) error 4 mm" in scene.stamp.get_text()


def test_over_without_a_reference_or_with_the_wrong_one_is_one_line(pair, tmp_path, capsys):
    ref, _, ref_path, pred_path = pair
    cases = [(["plot", str(ref_path), "--over", "--node", "2"],
              ["--over", "records no reference data set", "--over REFERENCE.h5"]),
             (["plot", str(pred_path), "--over", str(pred_path)], ["--over", "another file"]),
             (["animate", str(pred_path), "--over", str(ref_path), "--style", "fluoroscopy"], ["--style", "--over"])]
    other = tmp_path / "other.h5"
    late = Dataset(time=ref.time + 1.0, nodes=ref.nodes, positions=ref.positions, quaternions=ref.quaternions,
                   forces=ref.forces, torques=ref.torques)
    write_trajectory(other, late, dt=0.01)
    cases.append((["animate", str(pred_path), "--over", str(other), "-o", str(tmp_path / "x.gif"), "--quiet"],
                  ["no sample at t = 0.1 s", "--over"]))
    for argv, words in cases + [(None, None)]:
        if argv is None:                       # the recorded reference is gone
            pred_path.rename(tmp_path / "moved.h5")
            ref_path.rename(tmp_path / "gone.h5")
            argv, words = ["plot", str(tmp_path / "moved.h5"), "--over"], ["records its reference as", "--over REF"]
        before = sorted(p.name for p in tmp_path.iterdir())
        assert run_cli(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "Traceback" not in err and "None" not in err, err
        for w in words:
            assert w in err, err
        assert sorted(p.name for p in tmp_path.iterdir()) == before


# ------------------------------------------------------------------------------------------ inputs
def test_plot_has_a_panel_per_unit_of_the_inputs(pair, tmp_path):
    ref = pair[0]
    fig = pictures.plot_node(ref, 5)
    labels = [ax.get_ylabel() for ax in fig.get_axes()]
    assert labels == ["x [mm]", "y [mm]", "z [mm]", "input [N]", "input [mm]"]   # no forces: no force panel
    tensions = fig.get_axes()[3]
    assert [line.get_label() for line in tensions.get_lines()] == ["tendon_1", "tendon_2"]
    np.testing.assert_allclose(tensions.get_lines()[1].get_ydata(), np.cos(ref.time), rtol=1e-6)
    assert [ax.get_ylabel() for ax in pictures.plot_node(ref, 5, inputs=False).get_axes()] == labels[:3]


def test_cli_plot_shows_the_inputs_of_a_time_span(pair, tmp_path, monkeypatch):
    _, _, ref_path, _ = pair
    seen = []
    real = pictures.node_panels
    monkeypatch.setattr(pictures, "node_panels", lambda *a, **k: seen.append(k) or real(*a, **k))
    assert run_cli(["plot", str(ref_path), "--node", "5", "--start", "0.1", "--stop", "0.2"]) == 0
    assert seen[0]["inputs"].shape == (11, 3) and list(seen[0]["units"]) == ["tendon_1", "tendon_2", "servo"]
    assert run_cli(["plot", str(ref_path), "--node", "5", "--no-inputs", "--overwrite"]) == 0
    assert seen[1]["inputs"] is None


def test_show_lists_the_inputs_with_units_and_ranges(pair, capsys):
    assert run_cli(["show", str(pair[2]), "--quick"]) == 0
    out = capsys.readouterr().out
    assert "actuation: 3 channels: tendon_1 [N] 0 .. 0.3894, tendon_2 [N] 0.9211 .. 1" in out
    assert "servo [mm] 0 .. 4" in out


# ------------------------------------------------------------------------------------------ one node
def test_plot_of_a_one_node_recording_needs_no_node(tmp_path, capsys):
    ref = reference_data()
    tip = Dataset(time=ref.time, nodes=np.array([10]), positions=ref.positions[:, -1:],
                  quaternions=ref.quaternions[:, -1:], forces=ref.forces[:, -1:], torques=ref.torques[:, -1:],
                  actuation=ref.actuation, actuation_units=ref.actuation_units)
    path = tmp_path / "tip.h5"
    write_trajectory(path, tip, dt=0.01)
    assert run_cli(["plot", str(path)]) == 0
    assert (tmp_path / "tip_node10.png").exists() and "wrote" in capsys.readouterr().out


# ------------------------------------------------------------------------------------------ the view
def _vessel(points):
    return {"kind": "vessel", "points": np.asarray(points, dtype=float), "radii": np.full(len(points), 0.0035)}


def test_the_plane_of_a_flat_vessel():
    trunk = _vessel([[-0.035, 0, 0], [0.02, 0, 0]])
    left = _vessel([[0.02, 0, 0], [0.043, 0.0086, 0]])
    right = _vessel([[0.02, 0, 0], [0.043, -0.0086, 0]])
    assert geometry.vessel_plane([trunk, left, right]) == "xy"
    assert geometry.vessel_plane([trunk]) is None                    # a straight vessel lies in many planes
    assert geometry.vessel_plane([]) is None and geometry.vessel_plane([{"kind": "sphere"}]) is None
    bent = _vessel([[0, 0, 0], [0.02, 0, 0.01], [0.04, 0.02, 0.03]])
    assert geometry.vessel_plane([bent]) is None
    assert geometry.vessel_plane([_vessel([[0, 0, 0], [0.02, 0, 0.01], [0.04, 0, 0.0]])]) == "xz"


def test_animate_shows_a_rod_sagging_in_a_flat_vessel_from_above(tmp_path, monkeypatch):
    """The bifurcation's case: the vessel lies in z = 0, the rod sags in z (3-D motion); 'auto' looks
    along z, at the rod inside the vessel (an X-ray picture), '--view 3d' still gives 3-D."""
    T, n = 6, 8
    time = np.linspace(0.0, 0.05, T)
    pos = np.zeros((T, n, 3))
    pos[:, :, 0] = np.linspace(-0.025, 0.02, n)
    pos[:, :, 1] = 0.002 * np.linspace(0, 1, n) * time[:, None] / time[-1]
    pos[:, :, 2] = -0.002 * np.linspace(0, 1, n) ** 2
    vessels = [_vessel([[-0.035, 0, 0], [0.02, 0, 0]]), _vessel([[0.02, 0, 0], [0.043, 0.0086, 0]]),
               _vessel([[0.02, 0, 0], [0.043, -0.0086, 0]])]
    data = SimpleNamespace(time=time, nodes=np.arange(n), positions=pos, attrs={"name": "vessel"})
    assert geometry.choose_view(pos) == "3d"
    seen = []
    monkeypatch.setattr(animation, "write_movie", lambda scene, *a, **k: seen.append(scene))
    monkeypatch.setattr(animation, "obstacles_of", lambda source: vessels)
    animation.animate(data, tmp_path / "a.gif", frames=2, obstacles={"obstacles": []}, style="auto")
    animation.animate(data, tmp_path / "b.gif", frames=2, obstacles={"obstacles": []}, style="plain")
    animation.animate(data, tmp_path / "c.gif", frames=2, obstacles={"obstacles": []}, view="3d", style="auto")
    assert [type(s).__name__ for s in seen] == ["FluoroScene", "_Scene", "_Scene"]
    assert [s.view for s in seen] == ["xy", "xy", "3d"]


# ------------------------------------------------------------------------------------------ end to end
def test_rollout_suggests_the_overlay_and_it_draws(tmp_path, capsys):
    pytest.importorskip("torch")
    from softrnn.learned.node.artifact import save_model
    from softrnn.learned.node.data import SampleSpec

    from helpers import N_NODES, node_dataset, real_model, save_h5

    ds = node_dataset(T=50)
    data = save_h5(tmp_path / "data.h5", ds, scenario_name="synthetic")
    folders = []
    for a in range(1, N_NODES):
        folders.append(tmp_path / f"node{a}")
        save_model(folders[-1], real_model(ds, SampleSpec(node=a, history=2, wrench="force")))
    pred = tmp_path / "pred.h5"
    assert run_cli(["rollout", *map(str, folders), str(data), "-o", str(pred), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert f"softrnn animate {pred} --over {data}" in out and f"softrnn plot {pred} --over {data}" in out
    assert "beside" not in out
    assert run_cli(["plot", str(pred), "--over", "-o", str(tmp_path / "p.png")]) == 0
    assert run_cli(["animate", str(pred), "--over", "-o", str(tmp_path / "a.gif"), "--frames", "3",
                    "--size", "160x128", "--quiet"]) == 0
    assert f"over {data}" in capsys.readouterr().out
    with Image.open(tmp_path / "a.gif") as im:
        assert im.n_frames == 3
