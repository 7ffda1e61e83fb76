"""Pictures: the rod animation (GIF frames, size, view, arrows) and the node plot, through the library
and the CLI; bad input is one line with exit code 2 and leaves no file, an interrupted write neither."""

from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from softrnn.cli._plot import named_node
from softrnn.errors import SoftrnnInputError
from softrnn.figures import _movie, animation, geometry, pictures
from softrnn.figures import data as figure_data
from softrnn.scenarios.scenario import scenario_text

from helpers import run_cli, without_record_builder


def rod_data(n_samples=41, n_nodes=11, planar=False, force=True):
    """A cantilever along +x swinging in y (and z unless planar), a force on the tip for t < 0.2 s."""
    time = np.linspace(0.0, 0.4, n_samples)
    s = np.linspace(0.0, 0.5, n_nodes)
    pos = np.zeros((n_samples, n_nodes, 3))
    pos[:, :, 0] = s
    pos[:, :, 1] = 0.1 * np.sin(2 * np.pi * time)[:, None] * (s / 0.5) ** 2
    if not planar:
        pos[:, :, 2] = -0.05 * (1 - np.cos(2 * np.pi * time))[:, None] * (s / 0.5) ** 2
    forces = np.zeros_like(pos)
    if force:
        forces[time < 0.2, -1] = (0.0, 0.5, -0.2)
    quats = np.zeros((n_samples, n_nodes, 4))
    quats[..., 0] = 1.0
    return SimpleNamespace(time=time, nodes=np.arange(n_nodes), positions=pos, quaternions=quats,
                           forces=forces, torques=np.zeros_like(pos), attrs={"case": "test rod"})


@pytest.fixture
def h5(tmp_path):
    from softrnn.io import write_trajectory

    path = tmp_path / "rod.h5"
    write_trajectory(path, rod_data(), dt=0.01, attrs={"node_of_interest": 10})
    return path


def files_in(folder):
    return sorted(p.name for p in folder.iterdir())


# ------------------------------------------------------------------------------------------ library


def test_gif_has_the_requested_frames_and_size(tmp_path):
    out = tmp_path / "rod.gif"
    assert animation.animate(rod_data(), out, frames=7, size=(240, 200), node=10) == out
    with Image.open(out) as im:
        assert im.n_frames == 7
        assert im.size == (240, 200)
        assert im.info["duration"] == 50  # 20 fps
    assert files_in(tmp_path) == ["rod.gif"]  # no temporary file left


def test_frame_choice_covers_the_record():
    idx = figure_data.frame_indices(50001)
    assert len(idx) == figure_data.DEFAULT_MAX_FRAMES and idx[0] == 0 and idx[-1] == 50000
    assert np.ptp(np.diff(idx)) <= 1  # evenly spaced
    assert list(figure_data.frame_indices(5)) == [0, 1, 2, 3, 4]  # never more frames than samples
    assert len(figure_data.frame_indices(1000, duration=2.0, fps=10)) == 20
    assert list(figure_data.frame_indices(11, frames=3, first=100)) == [100, 105, 110]
    with pytest.raises(SoftrnnInputError, match="give one of them"):
        figure_data.frame_indices(10, frames=3, duration=1.0)


def test_view_and_arrow_scale():
    assert geometry.choose_view(rod_data(planar=True).positions) == "xy"
    assert geometry.choose_view(rod_data().positions) == "3d"
    yz = rod_data(planar=True).positions[..., [2, 0, 1]]  # (0, x, y): flat along x
    assert geometry.choose_view(yz) == "yz"
    k, ref, length = geometry.force_scale(1.0, 0.5)  # 1 N on a 0.5 m picture
    assert (k, ref, length) == (0.1, 1.0, 0.1)  # "1 N = 0.1 m": the largest arrow is 20 % of the extent
    k, ref, length = geometry.force_scale(0.092, 0.5)
    assert ref == pytest.approx(0.05) and 0.1 * 0.5 <= k * 0.092 <= 0.2 * 0.5


def test_node_of_interest_from_attrs_or_scenario():
    d = rod_data()
    assert figure_data.node_of_interest(d) is None
    d.attrs = {"node_of_interest": 7}
    assert figure_data.node_of_interest(d) == 7
    d.attrs = {"scenario_record": {"version": 1, "name": "x", "nodes_of_interest": [10]}, "n_nodes_total": 11}
    assert figure_data.node_of_interest(d) == 10
    d.attrs = {"scenario_text": scenario_text("square"), "n_nodes_total": 51}   # an older file: no record
    with without_record_builder():          # as where softrnn.scenarios is not imported
        assert figure_data.node_of_interest(d) is None and named_node(d) == 50   # the command line rebuilds it
    assert figure_data.node_of_interest(d) == 50     # softrnn.scenarios imported: its builder rebuilds it
    d.attrs = {"case": "semicircle"}
    assert named_node(d) == 50  # the paper case's node: the command line looks it up


def test_the_caller_gives_the_node_the_data_does_not_hold():
    d = rod_data()
    d.attrs = {"case": "semicircle"}  # a paper case's name only: figures do not read scenarios
    assert figure_data.node_of_interest(d) is None
    assert figure_data.node_of_interest(d, default=50) == 50
    assert figure_data.node_of_interest(d, default=-1) == 10  # counted from the rod's end
    d.attrs = {"case": "semicircle", "node_of_interest": 7}
    assert figure_data.node_of_interest(d, default=50) == named_node(d) == 7  # what the data names comes first


def test_planar_3d_and_forceless_animations_render(tmp_path):
    animation.animate(rod_data(planar=True), tmp_path / "flat.gif", frames=3, size=(160, 140))
    animation.animate(rod_data(force=False), tmp_path / "free.gif", frames=3, size=(160, 140), trail=False)
    animation.animate(rod_data(), tmp_path / "span.gif", start=0.1, stop=0.3, size=(160, 140), max_frames=4)
    for name in ("flat", "free", "span"):
        with Image.open(tmp_path / f"{name}.gif") as im:
            assert im.n_frames in (3, 4)


def test_interrupted_animation_leaves_no_file(tmp_path, monkeypatch):
    calls = []

    def update(self, i):
        calls.append(i)
        if len(calls) == 3:
            raise KeyboardInterrupt

    monkeypatch.setattr(animation._Scene, "update", update)
    with pytest.raises(KeyboardInterrupt):
        animation.animate(rod_data(), tmp_path / "rod.gif", frames=10, size=(160, 140))
    assert files_in(tmp_path) == []
    calls.clear()
    monkeypatch.setattr(_movie.GifSink, "finish", lambda self: (_ for _ in ()).throw(OSError("disk full")))
    with pytest.raises(OSError):
        animation.animate(rod_data(), tmp_path / "rod.gif", frames=2, size=(160, 140))
    assert files_in(tmp_path) == []


def test_existing_file_is_kept_when_a_new_write_fails(tmp_path, monkeypatch):
    out = tmp_path / "rod.gif"
    out.write_bytes(b"old")
    monkeypatch.setattr(animation._Scene, "update", lambda self, i: (_ for _ in ()).throw(RuntimeError("boom")))
    with pytest.raises(RuntimeError):
        animation.animate(rod_data(), out, frames=3, size=(160, 140))
    assert out.read_bytes() == b"old" and files_in(tmp_path) == ["rod.gif"]


def test_plot_node_writes_a_png(tmp_path):
    out = tmp_path / "node.png"
    assert pictures.plot_node(rod_data(), 10, out) == out
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(out) as im:
        assert im.size[0] > 500 and im.size[1] > 500
    assert files_in(tmp_path) == ["node.png"]
    with pytest.raises(SoftrnnInputError, match=r"node=99 .* 0\.\.10"):
        pictures.plot_node(rod_data(), 99, tmp_path / "x.png")


# ------------------------------------------------------------------------------------------ CLI


def test_cli_animate_and_plot(h5, tmp_path, capsys):
    gif = tmp_path / "out" / "rod.gif"
    assert run_cli(["animate", str(h5), "-o", str(gif), "--frames", "4", "--size", "200x160", "--quiet"]) == 0
    with Image.open(gif) as im:
        assert (im.n_frames, im.size) == (4, (200, 160))
    png = tmp_path / "node3.png"
    assert run_cli(["plot", str(h5), "--node", "3", "-o", str(png)]) == 0
    assert png.stat().st_size > 1000
    assert run_cli(["plot", str(h5), "--start", "0.1", "--stop", "0.3"]) == 0  # node of interest, default name
    assert (tmp_path / "rod_node10.png").exists()
    out = capsys.readouterr().out
    assert "wrote" in out and str(gif) in out


@pytest.mark.parametrize("argv, words", [
    (["animate", "{h5}", "-o", "{tmp}/rod.avi"], ["'.avi'", ".gif", ".mp4"]),
    (["animate", "{h5}", "-o", "{tmp}/rod"], ["(none)", ".gif"]),
    (["plot", "{h5}", "--node", "3", "-o", "{tmp}/node.gif"], ["'.gif'", ".png"]),
    (["plot", "{h5}", "--node", "99", "-o", "{tmp}/node.png"], ["node 99", "0..10"]),
    (["plot", "{h5}", "--node", "-99", "-o", "{tmp}/node.png"], ["node -99", "0..10"]),
    (["animate", "{h5}", "--node", "42", "-o", "{tmp}/rod.gif"], ["node 42", "0..10"]),
    (["animate", "{tmp}/missing.h5", "-o", "{tmp}/rod.gif"], ["missing.h5", "no such file"]),
    (["plot", "{tmp}/missing.h5", "--node", "1", "-o", "{tmp}/n.png"], ["missing.h5", "no such file"]),
    (["animate", "{h5}", "-o", "{tmp}/rod.gif", "--start", "5"], ["--start=5.0", "[0, 0.4] s"]),
    (["animate", "{h5}", "-o", "{tmp}/rod.gif", "--start", "0.3", "--stop", "0.1"], ["--stop=0.1", "after"]),
    (["animate", "{h5}", "-o", "{tmp}/rod.gif", "--frames", "0"], ["--frames=0", ">= 1"]),
    (["animate", "{h5}", "-o", "{tmp}/rod.gif", "--size", "big"], ["--size='big'", "WIDTHxHEIGHT"]),
    (["animate", "{h5}", "-o", "{tmp}/rod.gif", "--frames", "3", "--playback", "1"], ["not allowed with"]),
    (["animate", "{notes}", "-o", "{tmp}/rod.gif"], ["notes.txt", "not an HDF5 file"]),
])
def test_cli_bad_input_is_one_line_exit_2_no_file(argv, words, h5, tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("not a dataset")
    before = files_in(tmp_path)
    argv = [a.format(h5=h5, tmp=tmp_path, notes=tmp_path / "notes.txt") for a in argv]
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("softrnn: error:") and "Traceback" not in err
    for w in words:
        assert w in err, err
    assert files_in(tmp_path) == before  # no output, no temporary file


def test_cli_plot_needs_a_node_when_the_file_names_none(tmp_path, capsys):
    from softrnn.io import write_trajectory

    path = tmp_path / "plain.h5"
    write_trajectory(path, rod_data(), dt=0.01)
    assert run_cli(["plot", str(path)]) == 2
    err = capsys.readouterr().err
    assert "--node" in err and "0..10" in err and len(err.strip().splitlines()) == 1
    assert run_cli(["plot", str(path), "--node", "-1"]) == 0  # counted from the rod's end
    assert (tmp_path / "plain_node10.png").exists()


def test_cli_mp4_without_ffmpeg_says_so(h5, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(figure_data.shutil, "which", lambda name: None)
    assert run_cli(["animate", str(h5), "-o", str(tmp_path / "rod.mp4")]) == 2
    err = capsys.readouterr().err
    assert "ffmpeg" in err and ".gif" in err
    assert not (tmp_path / "rod.mp4").exists()


def test_cli_interrupted_animation_leaves_no_file(h5, tmp_path, monkeypatch, capsys):
    def update(self, i):
        raise KeyboardInterrupt

    monkeypatch.setattr(animation._Scene, "update", update)
    before = files_in(tmp_path)
    assert run_cli(["animate", str(h5), "-o", str(tmp_path / "rod.gif"), "--quiet"]) == 130
    assert files_in(tmp_path) == before


@pytest.mark.skipif(figure_data.shutil.which("ffmpeg") is None, reason="ffmpeg is not installed")
def test_mp4_with_ffmpeg(tmp_path):
    out = animation.animate(rod_data(), tmp_path / "rod.mp4", frames=5, size=(161, 141))
    assert out.stat().st_size > 1000
    assert files_in(tmp_path) == ["rod.mp4"]
