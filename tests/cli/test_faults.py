"""Faults a user's machine throws: a full disk, a vanished or unwritable output folder, a file
changed while it is read, a request too large for the free disk. Each ends in one line naming what
happened and the fix, exit code 2, no partial or temporary file, finished work kept.

A full disk is real where it can be: a child process under a small file-size limit
(``RLIMIT_FSIZE``, which Python's ignored SIGXFSZ turns into EFBIG on the write that crosses it,
as ENOSPC on a full disk); elsewhere a patched write raises ``OSError(errno.ENOSPC)``."""

import errno
import os
import resource
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from softrnn import files
from softrnn.errors import FileFault
from softrnn.io import DatasetWriter, _h5files, read_dataset, write_trajectory
from softrnn.io.csv_table import read_text_file
from softrnn.io.schema import DatasetError, trajectory_bytes

from helpers import run_cli
from helpers import swinging_rod as synthetic

TIMEOUT_S = 600
POSIX = pytest.mark.skipif(sys.platform == "win32", reason="POSIX file-size limits")


def _command() -> list:
    return [sys.executable, "-m", "softrnn.cli.main"]


def _limited(limit_bytes: int):
    """preexec_fn: a child whose files may not grow past ``limit_bytes`` (a full disk's stand-in)."""
    def apply():
        soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, hard))
    return apply


def _run(argv, cwd, limit_bytes=None) -> subprocess.CompletedProcess:
    return subprocess.run(_command() + argv, cwd=cwd, capture_output=True, text=True, timeout=TIMEOUT_S,
                          preexec_fn=None if limit_bytes is None else _limited(limit_bytes))


def _one_line(text: str, *words) -> str:
    text = text.strip()
    assert text.startswith("softrnn: error:") and "\n" not in text, text
    for w in ("Traceback", "HDF5-DIAG", "Segmentation"):
        assert w not in text, text
    for w in words:
        assert w in text, (w, text)
    return text


def _child_error(stderr: str, *words) -> str:
    """The one ``softrnn:`` line of a child's stderr (Dask may warn beside it, e.g. of a busy port),
    with nothing of a crash or an HDF5 error stack anywhere."""
    for w in ("Traceback", "HDF5-DIAG", "Segmentation"):
        assert w not in stderr, stderr
    lines = [line for line in stderr.splitlines() if line.startswith("softrnn")]
    assert len(lines) == 1, stderr
    return _one_line(lines[0], *words)


def _one_line_error(capsys, *words) -> str:
    return _one_line(capsys.readouterr().err, *words)


def _names(folder: Path) -> list:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def _no_space(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


# ------------------------------------------------------------------------------------- a full disk, for real
@POSIX
def test_simulate_onto_a_full_disk_is_one_line_and_no_crash(tmp_path):
    """Today's crash: HDF5 cannot close a file whose write failed; the writer discards it first."""
    argv = ["simulate", "tendon-spatial", "--samples", "400", "--quiet", "-o", str(tmp_path / "run.h5")]
    warm = _run(argv, tmp_path)            # compiles (numba's cache is written outside the limit)
    assert warm.returncode == 0, warm.stderr
    size = (tmp_path / "run.h5").stat().st_size
    (tmp_path / "run.h5").unlink()
    proc = _run(argv, tmp_path, limit_bytes=size // 3)
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    _child_error(proc.stderr, f"cannot write {tmp_path / 'run.h5'}", "File too large", "ulimit -f",
              "no partial file was left")
    assert _names(tmp_path) == []


@POSIX
def test_sweep_onto_a_full_disk_keeps_the_finished_variants(tmp_path):
    pytest.importorskip("distributed")
    out = tmp_path / "sweep"
    base = ["sweep", "tendon-planar", "-o", str(out), "--samples", "200", "--workers", "1", "--quiet"]
    first = _run(base + ["--count", "2"], tmp_path)
    assert first.returncode == 0, first.stderr
    size = (out / "traj-00000.h5").stat().st_size
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    proc = _run(base + ["--count", "4"], tmp_path, limit_bytes=size // 2)
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    _child_error(proc.stderr, "cannot write", "traj-0000", "the 2 finished variants are kept", "run the same command")
    assert _names(out) == ["sweep.json", "traj-00000.h5", "traj-00001.h5"]
    assert {p.name: p.read_bytes() for p in out.glob("traj-*")} == {k: v for k, v in before.items() if "traj" in k}
    again = _run(base + ["--count", "4"], tmp_path)       # room again: the rerun continues
    assert again.returncode == 0, again.stderr
    assert "2 computed" in again.stdout and "2 already there" in again.stdout


@POSIX
def test_train_onto_a_full_disk_leaves_no_model_folder(tmp_path):
    pytest.importorskip("torch")
    data = tmp_path / "data.h5"
    write_trajectory(data, synthetic(300), dt=0.01)
    out = tmp_path / "model"
    proc = _run(["train", str(data), "--node", "2", "-o", str(out), "--epochs", "2", "--units", "8", "--dense", "8",
                 "--batch-size", "64", "--quiet"], tmp_path, limit_bytes=4096)
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    _child_error(proc.stderr, "cannot write", "checkpoint.pt", "File too large")
    assert _names(tmp_path) == ["data.h5"]


# ------------------------------------------------------------------------------------ a full disk, patched
def test_a_checkpoint_that_fails_keeps_the_last_one(tmp_path, monkeypatch, capsys):
    """The second epoch's checkpoint meets a full disk: the first is kept, --resume finishes."""
    pytest.importorskip("torch")
    data = tmp_path / "data.h5"
    write_trajectory(data, synthetic(300), dt=0.01)
    out = tmp_path / "model"
    argv = ["train", str(data), "--node", "2", "-o", str(out), "--epochs", "3", "--units", "8", "--dense", "8",
            "--batch-size", "64", "--quiet"]
    replace, calls = os.replace, []

    def full_on_the_second(src, dst, *a, **k):
        if str(dst).endswith("checkpoint.pt"):
            calls.append(dst)
            if len(calls) == 2:
                raise OSError(errno.ENOSPC, "No space left on device")
        return replace(src, dst, *a, **k)

    monkeypatch.setattr(os, "replace", full_on_the_second)
    assert run_cli(argv) == 2
    _one_line_error(capsys, f"cannot write {out / 'checkpoint.pt'}", "No space left on device", "free space",
                    f"the last finished epoch is kept in {out / 'checkpoint.pt'}", "--resume")
    assert _names(out) == ["checkpoint.pt"]
    monkeypatch.setattr(os, "replace", replace)
    assert run_cli(argv + ["--resume"]) == 0
    assert (out / "config.json").is_file() and not (out / "checkpoint.pt").exists()


def test_a_model_folder_that_fails_is_left_as_it_was(tmp_path, monkeypatch):
    pytest.importorskip("torch")
    from softrnn.learned import artifacts

    monkeypatch.setattr(artifacts.Path, "write_bytes", lambda self, data: _no_space())
    with pytest.raises(FileFault, match=r"cannot write .*model: No space left on device; free space on the disk"):
        files.atomic_folder(tmp_path / "model", lambda tmp: artifacts.write_tensors(tmp / "w.safetensors", {}))
    assert _names(tmp_path) == []


class _FullFile:
    """A file object whose writes meet a full disk."""

    def __init__(self, *args, **kwargs):
        self.name = args[0]

    def write(self, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_a_text_file_onto_a_full_disk_names_the_path(tmp_path, monkeypatch):
    """CSVs, JSON reports and figures write through ``atomic_output``: the path is named, not the temporary."""
    out = tmp_path / "rec.csv"
    out.write_text("old")
    monkeypatch.setattr(files, "open", _FullFile, raising=False)
    with pytest.raises(FileFault) as info:
        files.atomic_write_text(out, "time\n0\n")
    text = str(info.value)
    assert text.startswith(f"cannot write {out}: No space left on device; free space on the disk of {tmp_path}")
    assert ".tmp" not in text and text.endswith("no partial file was left")
    assert _names(tmp_path) == ["rec.csv"] and out.read_text() == "old"


def test_lab_example_onto_a_full_disk_leaves_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(files, "open", _FullFile, raising=False)
    out = tmp_path / "lab"
    assert run_cli(["lab-example", "-o", str(out), "--duration", "2", "--quiet"]) == 2
    _one_line_error(capsys, f"cannot write {out / 'tendon-spatial.csv'}: No space left on device", "free space")
    assert _names(tmp_path) == []


def test_a_full_disk_while_streaming_a_dataset_discards_it(tmp_path, monkeypatch):
    traj = synthetic(5000)
    path = tmp_path / "run.h5"
    writer = DatasetWriter(path, nodes=traj.nodes, n_samples=5000, dt=0.01)
    original = _h5files.h5py.Dataset.__setitem__

    def full(self, key, value):
        raise OSError(errno.ENOSPC, "Can't write data (file write failed: errno = 28)")

    monkeypatch.setattr(_h5files.h5py.Dataset, "__setitem__", full)
    with pytest.raises(FileFault, match=f"cannot write {path}: No space left on device"):
        writer.append(traj)
    monkeypatch.setattr(_h5files.h5py.Dataset, "__setitem__", original)
    assert _names(tmp_path) == []
    writer.abort()                          # idempotent after the fault


def test_an_escaping_full_disk_without_a_file_name_is_one_line(monkeypatch, capsys):
    """e.g. numba writing its cache of compiled code onto a full disk."""
    monkeypatch.setattr("softrnn.scenarios.summary.simulate_summary", _no_space)
    assert run_cli(["simulate", "semicircle", "--samples", "5", "--quiet"]) == 2
    _one_line_error(capsys, "a write failed: No space left on device", "free space")


# ----------------------------------------------------------------------------- a vanished or unwritable folder
def test_an_output_folder_removed_while_writing(tmp_path):
    folder = tmp_path / "out"
    traj = synthetic(50)
    writer = DatasetWriter(folder / "run.h5", nodes=traj.nodes, n_samples=50, dt=0.01)
    writer.append(traj)
    shutil.rmtree(folder)
    with pytest.raises(FileFault, match=rf"cannot write {folder / 'run.h5'}: No such file or directory; the folder "
                                        rf"{folder} was removed or moved while softrnn wrote into it"):
        writer.close()
    assert _names(tmp_path) == []


def test_a_folder_removed_as_the_file_is_made_is_one_line(tmp_path, monkeypatch):
    """HDF5 reports a folder that vanishes while it makes the file without an error number
    ("can't retrieve stat info"): the writer still names the vanished folder."""
    folder = tmp_path / "out"
    folder.mkdir()
    real = _h5files._h5open

    def vanish_then_open(path, mode="r"):
        f = real(path, mode)
        f.close()
        shutil.rmtree(folder)
        raise OSError("Unable to synchronously create file (can't retrieve stat info for file)")

    monkeypatch.setattr("softrnn.io.writer._h5open", vanish_then_open)
    with pytest.raises(FileFault, match=rf"cannot write {folder / 'run.h5'}: No such file or directory; the folder "
                                        rf"{folder} was removed or moved"):
        DatasetWriter(folder / "run.h5", nodes=np.arange(3), n_samples=5, dt=0.01)
    assert _names(tmp_path) == []


def test_simulate_into_a_folder_removed_meanwhile_is_one_line(tmp_path, monkeypatch, capsys):
    folder = tmp_path / "out"
    close = DatasetWriter.close

    def vanish_then_close(self):
        shutil.rmtree(folder, ignore_errors=True)
        close(self)

    monkeypatch.setattr(DatasetWriter, "close", vanish_then_close)
    assert run_cli(["simulate", "semicircle", "--samples", "5", "--quiet", "-o", str(folder / "run.h5")]) == 2
    _one_line_error(capsys, f"cannot write {folder / 'run.h5'}", "was removed or moved", "run again")
    assert _names(tmp_path) == []


def test_a_folder_made_unwritable_while_running_is_one_line(tmp_path, monkeypatch, capsys):
    """Permission denied when the temporary file is made (mocked: the tests may run as root)."""
    def denied(*args, prefix="", suffix="", dir=None, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied", str(Path(dir) / f"{prefix}abc{suffix}"))

    monkeypatch.setattr(files.tempfile, "mkstemp", denied)
    out = tmp_path / "summary.json"
    assert run_cli(["simulate", "semicircle", "--samples", "5", "--quiet", "--json", str(out)]) == 2
    _one_line_error(capsys, f"cannot write {out}: Permission denied", "make it writable or choose an output")
    assert _names(tmp_path) == []


@pytest.mark.skipif(sys.platform == "win32" or os.geteuid() == 0, reason="root writes into any folder")
def test_a_read_only_folder_for_real(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        with pytest.raises(FileFault, match="Permission denied.*make it writable"):
            files.atomic_write_text(folder / "x.txt", "x")
        with pytest.raises(FileFault, match="Permission denied.*make it writable"):
            write_trajectory(folder / "x.h5", synthetic(20), dt=0.01)
    finally:
        folder.chmod(0o700)
    assert _names(folder) == []


def test_a_sweep_folder_removed_while_it_runs_is_one_line_and_not_made_again(tmp_path, monkeypatch, capsys):
    """The folder goes after the first variant: the sweep stops (exit 2) naming the folder and the fix,
    and no worker makes the folder again, empty of its manifest."""
    pytest.importorskip("distributed")
    from softrnn.cli import _sweep

    out = tmp_path / "sweep"

    class Vanishing(_sweep.Bar):
        def __call__(self, done, total, info=None):
            while done == 1 and out.exists():          # a worker may be adding a file meanwhile
                shutil.rmtree(out, ignore_errors=True)

    bar = _sweep.Bar
    monkeypatch.setattr(_sweep, "Bar", Vanishing)
    argv = ["sweep", "tendon-planar", "--count", "4", "-o", str(out), "--samples", "20", "--workers", "1", "--quiet"]
    assert run_cli(argv) == 2
    err = _one_line_error(capsys, f"the sweep folder {out} was removed or moved while the sweep ran",
                          "put it back where it was", "run the same command again")
    assert "(1 of 4 variants finished)" in err
    assert _names(tmp_path) == []
    monkeypatch.setattr(_sweep, "Bar", bar)
    assert run_cli(argv) == 0                        # in place again: the same command runs
    assert "4 computed" in capsys.readouterr().out


def test_a_sweep_folder_moved_while_it_runs_keeps_its_variants(tmp_path):
    """Moved aside after the first variant: the finished variants are in the moved folder, and moved
    back, the same sweep continues from them."""
    pytest.importorskip("distributed")
    from softrnn.scenarios.scenario import load_scenario
    from softrnn.sweeps.sweep import run_sweep

    out, aside = tmp_path / "sweep", tmp_path / "aside"

    def move(done, total, info=None):
        if done == 1:
            out.rename(aside)

    with pytest.raises(FileFault, match=rf"the sweep folder {out} was removed or moved .*a moved folder keeps"):
        run_sweep(load_scenario("tendon-planar"), 4, out, n_workers=1, n_samples=20, progress=move)
    assert not out.exists()
    assert "traj-00000.h5" in sorted(p.name for p in aside.glob("traj-*.h5"))
    aside.rename(out)
    again = run_sweep(load_scenario("tendon-planar"), 4, out, n_workers=1, n_samples=20)
    assert sorted(again.skipped + again.computed) == [0, 1, 2, 3] and 0 in again.skipped
    assert _names(out) == ["sweep.json", *(f"traj-0000{i}.h5" for i in range(4))]   # a temporary the move cut off: gone


def test_dynamic_train_whose_model_meets_a_full_disk_names_the_checkpoint_it_kept(tmp_path, monkeypatch, capsys):
    """The final save fails: the last step's checkpoint stays, named with the fix; --resume then saves
    the model without training again."""
    pytest.importorskip("torch")
    from softrnn.learned.whole import artifact
    from softrnn.scenarios.scenario import load_scenario
    from softrnn.scenarios.summary import simulate_summary

    data, sc = tmp_path / "data.h5", load_scenario("square")
    simulate_summary(name=sc.name, title=sc.title, setup=sc.setup, config=replace(sc.config, dt=0.01, n_samples=61),
                     node=sc.nodes_of_interest[0], out_path=str(data), scenario_text=sc.text, seed=sc.seed)
    out = tmp_path / "model"
    argv = ["dynamic", "train", str(data), "-o", str(out), "--steps", "3", "--model-dt", "0.02", "--node-stride", "10",
            "--width", "8", "--layers", "1", "--unroll", "2", "--threads", "1", "--quiet"]
    real = artifact.write_tensors
    monkeypatch.setattr(artifact, "write_tensors", lambda *a, **k: _no_space())
    assert run_cli(argv) == 2
    _one_line_error(capsys, f"cannot write {out}: No space left on device", "free space",
                    f"the training's last checkpoint is kept in {out / 'checkpoint.pt'}",
                    "run the same command with --resume")
    assert (out / "checkpoint.pt").is_file() and not (out / "model.json").exists()
    monkeypatch.setattr(artifact, "write_tensors", real)
    assert run_cli(argv + ["--resume"]) == 0
    assert (out / "model.json").is_file() and not (out / "checkpoint.pt").exists()


# ------------------------------------------------------------------------------ a file changed while read
def _appending_open(path: Path, data: bytes):
    """``open`` that, after the file is opened, appends ``data`` to it (a writer still at work)."""
    real = open

    class Changing:
        def __init__(self, name, mode="r", *args, **kwargs):
            self._fh = real(name, mode, *args, **kwargs)

        def fileno(self):
            return self._fh.fileno()

        def read(self, *args):
            with real(path, "ab") as other:
                other.write(data)
            return self._fh.read(*args)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self._fh.close()
            return False

    return Changing


def test_a_csv_changed_while_read_is_one_line(tmp_path, monkeypatch):
    csv = tmp_path / "rec.csv"
    csv.write_text("time,n1_x\n0,1\n0.1,2\n")
    assert "0.1,2" in read_text_file(csv, "the lab data")
    monkeypatch.setattr(files, "open", _appending_open(csv, b"0.2,3\n"), raising=False)
    with pytest.raises(DatasetError, match=rf"^{csv}: changed or truncated while reading; re-run when the writer "
                                           r"has finished$"):
        read_text_file(csv, "the lab data")


def test_a_recording_changed_while_imported_is_one_line(tmp_path, monkeypatch, capsys):
    csv = tmp_path / "rec.csv"
    shutil.copyfile(Path(__file__).resolve().parents[2] / "examples" / "lab_data.csv", csv)
    monkeypatch.setattr(files, "open", _appending_open(csv, b"9"), raising=False)
    assert run_cli(["import-csv", str(csv), "-o", str(tmp_path / "rec.h5")]) == 2
    _one_line_error(capsys, str(csv), "changed or truncated while reading", "re-run when the writer has finished")
    assert _names(tmp_path) == ["rec.csv"]


@pytest.mark.parametrize("change", ["append", "truncate"])
def test_a_dataset_changed_while_read_is_one_line(tmp_path, monkeypatch, capsys, change):
    path = tmp_path / "run.h5"
    write_trajectory(path, synthetic(300), dt=0.01)
    size = path.stat().st_size
    real = _h5files._h5open

    def changing_open(p, mode="r"):
        f = real(p, mode)
        if mode == "r":
            with open(path, "ab") as fh:
                if change == "append":
                    fh.write(b"\0" * 100)
                else:
                    fh.truncate(size // 2)
        return f

    monkeypatch.setattr(_h5files, "_h5open", changing_open)
    with pytest.raises(DatasetError, match="changed or truncated while reading; re-run when the writer has finished"):
        read_dataset(path)
    path.unlink()
    write_trajectory(path, synthetic(300), dt=0.01)
    assert run_cli(["show", str(path)]) == 2
    _one_line_error(capsys, str(path), "changed or truncated while reading")


def test_an_unchanged_dataset_reads_as_before(tmp_path):
    path = tmp_path / "run.h5"
    traj = synthetic(100)
    write_trajectory(path, traj, dt=0.01)
    np.testing.assert_allclose(read_dataset(path).positions, traj.positions, atol=1e-6)


# ------------------------------------------------------------------ a request larger than the free disk
def _free(n_bytes: int):
    def usage(path):
        return shutil._ntuple_diskusage(10 * n_bytes, 9 * n_bytes, n_bytes)
    return usage


def test_lab_example_larger_than_the_free_disk_is_refused_up_front(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(files.shutil, "disk_usage", _free(1_000_000))
    out = tmp_path / "lab"
    assert run_cli(["lab-example", "-o", str(out), "--rate", "2000", "--duration", "100", "--quiet"]) == 2
    err = _one_line_error(capsys, "2 recordings of 200001 rows (100 s at 2000 Hz) would take about", "MiB",
                          "has 977 KiB free", "use a lower --rate or a shorter --duration")
    assert str(out) in err
    assert _names(tmp_path) == []
    monkeypatch.setattr(files.shutil, "disk_usage", _free(10**12))      # the same request fits a large disk
    from softrnn.experiments import lab_example

    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(lab_example, "record", stop)
    with pytest.raises(KeyboardInterrupt):          # it got past the check, to the runs
        lab_example.write_lab_example(out, lab_example.LabExampleConfig(rate=2000, duration=100))


def test_lab_example_larger_than_memory_is_refused_up_front(tmp_path, capsys):
    assert run_cli(["lab-example", "-o", str(tmp_path / "lab"), "--rate", "1e7", "--quiet"]) == 2
    _one_line_error(capsys, "--rate=", "fits this machine's memory", "use a lower --rate or a shorter --duration")
    assert _names(tmp_path) == []


def test_simulate_larger_than_the_free_disk_is_refused_up_front(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(files.shutil, "disk_usage", _free(100_000))
    out = tmp_path / "run.h5"
    assert run_cli(["simulate", "tendon-spatial", "--samples", "100000", "--quiet", "-o", str(out)]) == 2
    raw = trajectory_bytes(100000, 41, 3)
    _one_line_error(capsys, f"cannot write {out}: the trajectory of 100000 samples of 41 nodes "
                            f"({raw / 2**30:.3g} GiB uncompressed) would take at least", "has 97.7 KiB free",
                    "save fewer samples or nodes")
    assert _names(tmp_path) == []


def test_sweep_larger_than_the_free_disk_is_refused_before_its_folder(tmp_path, monkeypatch, capsys):
    pytest.importorskip("distributed")
    monkeypatch.setattr(files.shutil, "disk_usage", _free(100_000))
    out = tmp_path / "sweep"
    assert run_cli(["sweep", "tendon-planar", "--count", "50", "-o", str(out), "--samples", "20000", "--quiet"]) == 2
    _one_line_error(capsys, "cannot write", "50 trajectories of 20000 samples of 41 nodes", "has 97.7 KiB free")
    assert _names(tmp_path) == []
