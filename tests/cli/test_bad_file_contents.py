"""Every CSV a command reads that is damaged or of the wrong kind is one line (exit 2, ``softrnn: error:``,
the file named), never a traceback, and leaves no output: ``import-csv`` (softrnn's node layout, a robot
recording, several sessions at once), ``lab benchmark`` and ``lab calibrate`` sessions, ``magnetic compare``'s
lab CSV and ``control magnetic --reference``'s CSV; each empty, random bytes, an HDF5 file or a workbook,
UTF-16 (with and without a byte-order mark), a folder, only a header, a wrong header, separated by semicolons
or tabs, a cell that is not a number or empty, a ragged row, NaN and inf cells, times that go back, repeat or
overflow, a long line of garbage and control characters. A session too short for the benchmark, a garbage
``.onnx`` file given where a model is read, a damaged control model and a damaged scenario or data set given
to ``softrnn calibrate`` are one line too. Models, normalisers, checkpoints and data sets of the other
commands: tests/cli/test_corrupt_inputs.py."""

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError

from helpers import node_dataset, run_cli, save_h5, tendon_recording

RANDOM = bytes(np.random.default_rng(0).integers(0, 256, 2000, dtype=np.uint8))
LONGEST = 1000
"""Most characters of an error line: a line of garbage is shortened, not repeated whole."""

NODES = "time,n0_x,n0_y,n0_z,n5_x,n5_y,n5_z\n" + "".join(
    f"{0.01 * k:g},0,0,0,0.25,{0.001 * k:g},0\n" for k in range(6))
RECORDING = "timestamp,pattern_label,servo_1_mm,servo_20_mm,servo_3_mm,tip_x,tip_y,tip_z\n" + "".join(
    f"{1775513850.3 + 0.6 * k:.6f},pull,{0.1 * k:g},{-0.2 * k:g},{0.05 * k:g},{-14 + k:g},{2 - k:g},{234 + k:g}\n"
    for k in range(8))
MAGNETIC = ("time,I0,I1,I2,I3,I4,I5,m0_rx,m0_ry,m0_rz,m1_rx,m1_ry,m1_rz\n" + "".join(
    f"{k / 30:.6f},1,-1,0.5,0,2,-2,0,{45 + k},0,0,{90 + k},0\n" for k in range(8)))
REFERENCE = "time,about_y_deg,about_x_deg\n" + "".join(f"{k},{95 + k},{k % 2}\n" for k in range(6))


def _cell(text, row, column, value):
    """``text`` with data row ``row`` (0-based, after the header), cell ``column`` replaced by ``value``."""
    lines = text.splitlines()
    cells = lines[row + 1].split(",")
    cells[column] = value
    lines[row + 1] = ",".join(cells)
    return "\n".join(lines) + "\n"


def _rows(text, order):
    lines = text.splitlines()
    return "\n".join([lines[0]] + [lines[1 + i] for i in order]) + "\n"


def _overflow(text):
    """Times -1.7e308, 1.7e308, 1.71e308, ...: increasing, but their first step is not a finite number."""
    lines = text.splitlines()
    times = [-1.7e308] + [1.7e308 + 1e305 * k for k in range(len(lines) - 2)]
    return "\n".join([lines[0]] + [f"{t!r}," + line.split(",", 1)[1] for t, line in zip(times, lines[1:])]) + "\n"


DAMAGE = {
    "empty": lambda text: b"",
    "random-bytes": lambda text: RANDOM,
    "hdf5": lambda text: b"\x89HDF\r\n\x1a\n" + RANDOM,
    "xlsx": lambda text: b"PK\x03\x04\x14\x00\x06\x00" + RANDOM,
    "utf16": lambda text: text.encode("utf-16"),
    "utf16-no-bom": lambda text: text.encode("utf-16-le"),
    "folder": None,
    "header-only": lambda text: text.splitlines()[0] + "\n",
    "wrong-header": lambda text: "a,b,c\n" + text.split("\n", 1)[1],
    "not-a-number": lambda text: _cell(text, 2, -1, "abc"),
    "empty-cell": lambda text: _cell(text, 2, -1, ""),
    "ragged-row": lambda text: _cell(text, 2, -1, "1,2"),
    "nan": lambda text: _cell(text, 2, -1, "nan"),
    "inf": lambda text: _cell(text, 2, -1, "-inf"),
    "time-nan": lambda text: _cell(text, 2, 0, "NaN"),
    "time-goes-back": lambda text: _rows(text, [0, 2, 1, *range(3, len(text.splitlines()) - 1)]),
    "time-repeats": lambda text: _rows(text, [0, 1, 1, *range(2, len(text.splitlines()) - 1)]),
    "time-overflow": _overflow,
    "semicolons": lambda text: text.replace(",", ";"),
    "tabs": lambda text: text.replace(",", "\t"),
    "long-garbage": lambda text: ("x" * 20000 + "\n") * 3,
    "garbage-text": lambda text: "\x1b[31m\x07 not,\x0f a CSV \u2603\n" * 5,
}


def _damaged(folder, good, case):
    """The damaged file ``folder/bad.csv`` (a folder of that name for ``folder``)."""
    path = folder / "bad.csv"
    if DAMAGE[case] is None:
        path.mkdir()
    else:
        content = DAMAGE[case](good)
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    return path


@pytest.fixture
def dirs(tmp_path):
    """(inputs folder, outputs folder): a command that fails leaves the outputs folder empty."""
    (tmp_path / "in").mkdir()
    (tmp_path / "out").mkdir()
    return tmp_path / "in", tmp_path / "out"


def _one_line(capsys, code, out_dir, *words):
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("softrnn: error:") and "Traceback" not in err, err
    assert len(err) < LONGEST, err
    for w in words:
        assert str(w) in err, err
    assert list(out_dir.iterdir()) == [], err


CASES = list(DAMAGE)


@pytest.mark.parametrize("case", CASES)
def test_import_csv_of_a_damaged_file_is_one_line(dirs, case, capsys):
    """The softrnn layout (``read_csv``); a robot recording (``read_recording``), on its own, read as a
    recording by ``--lag 0``, or the second of two sessions (beside a recording or a node-layout file) into a
    folder."""
    src, out = dirs
    bad = _damaged(src, NODES, case)
    _one_line(capsys, run_cli(["import-csv", str(bad), "-o", str(out / "x.h5")]), out, bad)
    if case != "folder":
        bad.unlink()
        bad = _damaged(src, RECORDING, case)
    _one_line(capsys, run_cli(["import-csv", str(bad), "-o", str(out / "x.h5")]), out, bad)
    _one_line(capsys, run_cli(["import-csv", str(bad), "-o", str(out / "x.h5"), "--lag", "0"]), out, bad)
    (src / "good.csv").write_text(RECORDING)
    (src / "nodes.csv").write_text(NODES)
    for first in ("good.csv", "nodes.csv"):
        _one_line(capsys, run_cli(["import-csv", str(src / first), str(bad), "-o", str(out / "sessions")]), out,
                  bad)


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    """A training and a validation session of a tendon robot (``tendon_recording``)."""
    d = tmp_path_factory.mktemp("sessions")
    tendon_recording(d / "train.csv", rows=40, seed=0)
    tendon_recording(d / "val.csv", rows=30, seed=1)
    return d


LAB = ["--length", "0.08", "--lag", "0", "--quiet"]


@pytest.mark.parametrize("case", CASES)
def test_lab_sessions_damaged_are_one_line(dirs, sessions, case, capsys):
    src, out = dirs
    good = (sessions / "train.csv").read_text()
    bad = _damaged(src, good, case)
    train, val = str(sessions / "train.csv"), str(sessions / "val.csv")
    bench = ["lab", "benchmark", "--json", str(out / "b.json"), "--figure", str(out / "b.png"), *LAB]
    _one_line(capsys, run_cli([*bench, "--train", train, str(bad), "--validate", val]), out, bad)
    _one_line(capsys, run_cli([*bench, "--train", train, "--validate", str(bad)]), out, bad)
    calibrate = ["lab", "calibrate", "-o", str(out / "robot.json"), *LAB]
    _one_line(capsys, run_cli([*calibrate, str(bad)]), out, bad)
    _one_line(capsys, run_cli([*calibrate, train, "--validate", str(bad)]), out, bad)


@pytest.mark.parametrize("rows", [1, 3, 5, 9])
def test_lab_benchmark_sessions_too_short_are_one_line(dirs, sessions, rows, capsys):
    """A session cut short (a recording stopped at once) is refused, not a least-squares error from the fits."""
    src, out = dirs
    lines = (sessions / "train.csv").read_text().splitlines()
    short = src / "short.csv"
    short.write_text("\n".join(lines[:rows + 1]) + "\n")
    train, val = str(sessions / "train.csv"), str(sessions / "val.csv")
    bench = ["lab", "benchmark", "--json", str(out / "b.json"), "--families", "physics", *LAB]
    _one_line(capsys, run_cli([*bench, "--train", str(short), "--validate", val]), out, short)
    _one_line(capsys, run_cli([*bench, "--train", train, "--validate", str(short)]), out, short)
    _one_line(capsys, run_cli([*bench, "--train", train, str(short), "--validate", val]), out, short)


@pytest.mark.parametrize("case", CASES)
def test_magnetic_compare_of_a_damaged_lab_csv_is_one_line(dirs, case, capsys):
    src, out = dirs
    bad = _damaged(src, MAGNETIC, case)
    _one_line(capsys, run_cli(["magnetic", "compare", str(bad), "-o", str(out / "lab"), "--workers", "1",
                               "--quiet"]), out, bad)


@pytest.mark.parametrize("case", CASES)
def test_control_with_a_damaged_reference_csv_is_one_line(dirs, case, capsys):
    src, out = dirs
    bad = _damaged(src, REFERENCE, case)
    _one_line(capsys, run_cli(["control", "magnetic", "--reference", str(bad), "--controller", "static-inverse",
                               "-o", str(out / "run"), "--duration", "1", "--quiet"]), out, bad)


def test_the_good_files_are_read(dirs, capsys):
    """The undamaged stand-ins above are valid, so every failure above is the damage's."""
    from softrnn.control.references import reference
    from softrnn.experiments.magnetic.lab import read_lab_csv
    from softrnn.io.csv_import import read_csv
    from softrnn.lab.recording import read_recording

    src, _ = dirs
    for name, text in (("nodes", NODES), ("recording", RECORDING), ("magnetic", MAGNETIC), ("reference", REFERENCE)):
        (src / f"{name}.csv").write_text(text)
    assert read_csv(src / "nodes.csv")["time"].size == 6
    assert read_recording(src / "recording.csv").n_rows == 8
    assert read_lab_csv(src / "magnetic.csv").n_samples == 8
    assert reference(str(src / "reference.csv"), duration=2.0).times.size == 61


# ------------------------------------------------------------------------------------- softrnn calibrate
TOML_DAMAGE = {
    "empty": b"",
    "random-bytes": RANDOM,
    "utf16": '[rod]\nlength = 0.5\n'.encode("utf-16"),
    "not-toml": b"time,n0_x,n0_y,n0_z\n0,0,0,0\n",
    "folder": None,
}


@pytest.mark.parametrize("case", list(TOML_DAMAGE))
def test_calibrate_with_a_damaged_scenario_or_data_file_is_one_line(dirs, data, case, capsys):
    """``softrnn calibrate DATA --scenario FILE.toml``: a damaged scenario file, and a damaged or foreign
    DATA (random bytes, a CSV, a folder), before any simulation."""
    src, out = dirs
    scenario = src / "s.toml"
    if TOML_DAMAGE[case] is None:
        scenario.mkdir()
    else:
        scenario.write_bytes(TOML_DAMAGE[case])
    argv = ["calibrate", "{data}", "--scenario", "{scenario}", "--fit", "rod.youngs_modulus", "-o",
            str(out / "f.toml"), "--quiet"]
    _one_line(capsys, run_cli([a.format(data=data, scenario=scenario) for a in argv]), out, scenario)
    dataset = src / "d.h5"
    if TOML_DAMAGE[case] is None:
        dataset.mkdir()
    else:
        dataset.write_bytes(TOML_DAMAGE[case])
    _one_line(capsys, run_cli([a.format(data=dataset, scenario="steel-wire") for a in argv]), out, dataset)


# ----------------------------------------------------------------------------------------------- ONNX
@pytest.fixture(scope="module")
def data(tmp_path_factory):
    return save_h5(tmp_path_factory.mktemp("onnx") / "d.h5", node_dataset(T=40))


ONNX_READERS = {
    "evaluate": ["evaluate", "{onnx}", "{data}", "--quiet"],
    "export": ["export", "{onnx}", "--onnx", "{out}/m.onnx"],
    "rollout": ["rollout", "{onnx}", "{data}", "-o", "{out}/r.h5", "--quiet"],
    "dynamic-evaluate": ["dynamic", "evaluate", "{onnx}", "--test", "{data}"],
    "dynamic-rollout": ["dynamic", "rollout", "{onnx}", "{data}", "-o", "{out}/r.h5"],
    "bench-model": ["bench", "--only", "model", "--model", "{onnx}", "--json", "{out}/b.json", "--quiet"],
    "bench-dynamic": ["bench", "--only", "dynamic", "--dynamic-model", "{onnx}", "--json", "{out}/b.json", "--quiet"],
    "control-model": ["control", "magnetic", "--reference", "step", "--controller", "mpc-learned", "--model",
                      "{onnx}", "-o", "{out}/run", "--duration", "1", "--quiet"],
}


@pytest.mark.parametrize("reader", list(ONNX_READERS))
def test_a_garbage_onnx_file_given_as_a_model_is_one_line(dirs, data, reader, capsys):
    pytest.importorskip("torch")
    src, out = dirs
    onnx = src / "model.onnx"
    onnx.write_bytes(RANDOM)
    argv = [a.format(onnx=onnx, data=data, out=out) for a in ONNX_READERS[reader]]
    _one_line(capsys, run_cli(argv), out, onnx)


def _zip_of_junk():
    import io
    import zipfile

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("junk.txt", "not a model")
    return buf.getvalue()


@pytest.mark.parametrize("case", ["empty", "random-bytes", "zip-signature", "zip-of-junk", "folder"])
def test_control_with_a_damaged_model_file_is_one_line(dirs, case, capsys):
    """``control magnetic --controller mpc-learned --model FILE``: refused by name before anything runs, not
    numpy's advice to load the file with ``allow_pickle``."""
    src, out = dirs
    model = src / "control-model.npz"
    content = {"empty": b"", "random-bytes": RANDOM, "zip-signature": b"PK\x03\x04 not a zip",
               "zip-of-junk": _zip_of_junk(), "folder": None}[case]
    model.mkdir() if content is None else model.write_bytes(content)
    code = run_cli(["control", "magnetic", "--reference", "step", "--controller", "mpc-learned", "--model", str(model),
                    "-o", str(out / "run"), "--duration", "1", "--quiet"])
    _one_line(capsys, code, out, "--model", model)


@pytest.mark.parametrize("content", [RANDOM, b"\x08\x07garbage"])
def test_onnx_metadata_of_a_garbage_file_is_one_line(tmp_path, content):
    pytest.importorskip("onnx")
    from softrnn.learned.node.export import onnx_metadata

    path = tmp_path / "model.onnx"
    path.write_bytes(content)
    with pytest.raises(SoftrnnInputError, match="ONNX file") as err:
        onnx_metadata(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)
