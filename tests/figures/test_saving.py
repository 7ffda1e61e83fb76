"""The one figure saver (``softrnn.figures.saving``): figures made without pyplot, written atomically
(a hidden temporary file in the same folder, then ``os.replace``), nothing partial left on error,
an existing file kept whole; and the figures package reads nothing from ``softrnn.scenarios``."""

import ast
import os
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

import softrnn.figures
from softrnn import files
from softrnn.figures import plots, saving

PNG = b"\x89PNG\r\n\x1a\n"


def files_in(folder):
    return sorted(p.name for p in folder.iterdir())


def a_figure():
    fig, ax = saving.subplots(figsize=(3, 2))
    ax.plot([0, 1, 2], [0, 1, 0])
    return fig


def test_a_figure_is_saved_whole_at_the_requested_size(tmp_path):
    out = tmp_path / "sub" / "f.png"          # a missing folder is made
    assert saving.save_figure(a_figure(), out) == out
    assert out.read_bytes()[:8] == PNG
    with Image.open(out) as im:
        assert im.size == (3 * saving.DPI, 2 * saving.DPI)
    assert files_in(out.parent) == ["f.png"]
    saving.save_figure(a_figure(), tmp_path / "g.png", dpi=50)
    with Image.open(tmp_path / "g.png") as im:
        assert im.size == (150, 100)
    mask = os.umask(0)
    os.umask(mask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~mask     # not mkstemp's 0600


@pytest.mark.parametrize("suffix, magic", [(".pdf", b"%PDF"), (".svg", b"<?xml")])
def test_the_suffix_names_the_format(tmp_path, suffix, magic):
    out = saving.save_figure(a_figure(), tmp_path / f"f{suffix}")
    assert out.read_bytes()[:len(magic)] == magic


def test_an_unsupported_suffix_leaves_no_file(tmp_path):
    (tmp_path / "old.xyz").write_bytes(b"old")
    with pytest.raises(ValueError, match="xyz"):
        saving.save_figure(a_figure(), tmp_path / "old.xyz")
    with pytest.raises(ValueError, match="xyz"):
        saving.save_figure(a_figure(), tmp_path / "new.xyz")
    assert files_in(tmp_path) == ["old.xyz"] and (tmp_path / "old.xyz").read_bytes() == b"old"


@pytest.mark.parametrize("error", [OSError("disk full"), KeyboardInterrupt()])
def test_a_failing_save_leaves_no_partial_file_and_keeps_the_old_one(tmp_path, monkeypatch, error):
    out = tmp_path / "f.png"
    out.write_bytes(b"old")

    def broken(self, fname, **kwargs):
        Path(fname).write_bytes(PNG + b"partial")   # half written, then the failure
        raise error

    monkeypatch.setattr(Figure, "savefig", broken)
    with pytest.raises(type(error)):
        saving.save_figure(a_figure(), out)
    with pytest.raises(type(error)):
        saving.save_figure(a_figure(), tmp_path / "new.png")
    assert files_in(tmp_path) == ["f.png"] and out.read_bytes() == b"old"


def test_the_file_is_replaced_in_one_rename_from_a_hidden_name_beside_it(tmp_path, monkeypatch):
    out = tmp_path / "f.png"
    out.write_bytes(b"old")
    renames = []
    real_replace = os.replace

    def replace(src, dst):
        renames.append((Path(src), Path(dst), Path(dst).read_bytes()))
        real_replace(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)  # the one temporary-file helper (softrnn.files)
    saving.save_figure(a_figure(), out)
    [(src, dst, before)] = renames
    assert dst == out and src.parent == tmp_path and src.name.startswith(".f.") and src.suffix == ".png"
    assert before == b"old"                      # the old file stays whole until the rename
    assert out.read_bytes()[:8] == PNG and files_in(tmp_path) == ["f.png"]


def test_atomic_output_removes_the_temporary_file_on_error(tmp_path):
    out = tmp_path / "movie.gif"
    with pytest.raises(RuntimeError):
        with saving.atomic_output(out) as tmp:
            Path(tmp).write_bytes(b"half")
            assert Path(tmp).parent == tmp_path and Path(tmp).name.startswith(".movie.")
            raise RuntimeError("boom")
    assert files_in(tmp_path) == []
    with saving.atomic_output(out) as tmp:
        Path(tmp).write_bytes(b"whole")
    assert files_in(tmp_path) == ["movie.gif"] and out.read_bytes() == b"whole"


def test_figure_bytes_match_the_saved_file(tmp_path):
    fig = a_figure()
    out = saving.save_figure(fig, tmp_path / "f.png")
    assert saving.figure_bytes(fig, ".png") == saving.figure_bytes(fig, "png") == out.read_bytes()


def test_no_pyplot_state_is_used(tmp_path):
    before = plt.get_fignums()
    t = np.linspace(0.0, 1.0, 20)
    fig = plots.node_trajectory(t, np.stack([t, t, t], axis=1), "node")
    assert isinstance(fig, Figure)
    saving.save_figure(fig, tmp_path / "node.png")
    saving.figure_bytes(saving.new_figure(figsize=(2, 2)), "png")
    assert plt.get_fignums() == before


def test_the_figures_package_does_not_import_pyplot(tmp_path):
    code = ("import sys\nimport numpy as np\n"
            "from softrnn.figures import animation, calibration, dynamic, evaluation, pictures, plots, saving\n"
            "t = np.linspace(0, 1, 5)\n"
            "saving.save_figure(plots.energy(t, np.ones((5, 3)), 'e'), 'e.png')\n"
            "print('matplotlib.pyplot' in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip() == "False" and (tmp_path / "e.png").is_file()


def test_figures_import_nothing_from_scenarios():
    """Imports anywhere in a module (inside functions too): figures sit below scenarios."""
    offenders = []
    for path in Path(softrnn.figures.__file__).parent.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            if any("scenarios" in n.split(".") for n in names):
                offenders.append(f"{path.name}:{node.lineno}")
    assert offenders == []
