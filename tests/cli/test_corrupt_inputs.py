"""Every file a command reads that is corrupt or of the wrong kind is one line (exit 2, ``softrnn: error:``,
the file named), never a traceback: node model folders (config.json, normalizer.json, meta.json,
weights.safetensors), whole-manipulator model folders (model.json, the weights), data sets; each
truncated, empty, random bytes, valid JSON of the wrong shape, missing, or a file of another kind."""

import json
import shutil

import numpy as np
import pytest

from softrnn.control.model import NarxModel
from softrnn.errors import SoftrnnInputError

from helpers import node_dataset, run_cli, save_h5

pytest.importorskip("torch")

NODE_TINY = ["--node", "2", "--epochs", "2", "--units", "8", "--layers", "1", "--dense", "8", "--rollout-steps", "1",
             "--quiet"]
DYN_TINY = ["--steps", "5", "--model-dt", "0.02", "--node-stride", "2", "--width", "8", "--layers", "1", "--unroll",
            "2", "--threads", "1", "--quiet"]
RANDOM = bytes(np.random.default_rng(0).integers(0, 256, 2000, dtype=np.uint8))


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A data set, a node model and a whole-manipulator model trained on it (tiny settings)."""
    root = tmp_path_factory.mktemp("corrupt")
    data = save_h5(root / "d.h5", node_dataset(T=120))
    assert run_cli(["train", str(data), "-o", str(root / "node"), *NODE_TINY]) == 0
    assert run_cli(["dynamic", "train", str(data), "-o", str(root / "dyn"), *DYN_TINY]) == 0
    return root


def _half(path):
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _json(member, change):
    def apply(path):
        doc = json.loads(path.read_text())
        change(doc)
        path.write_text(json.dumps(doc))
    return member, apply


def _replace(member, content):
    def apply(path):
        if content is None:
            path.unlink()
        elif content == "half":
            _half(path)
        else:
            path.write_bytes(content)
    return member, apply


def _damaged(member_content):
    return [(f"{m}-{tag}", _replace(m, c)) for m in member_content
            for tag, c in (("empty", b""), ("truncated", "half"), ("random", RANDOM), ("list", b"[]"),
                           ("missing", None))]


def _strings(doc):
    for key, value in doc.items():
        if isinstance(value, list):
            doc[key] = "x"


NODE = _damaged(("config.json", "normalizer.json", "meta.json", "weights.safetensors")) + [
    ("config-model-list", _json("config.json", lambda d: d.update(model=[1]))),
    ("config-version-str", _json("config.json", lambda d: d.update(format_version="1"))),
    ("normalizer-strings", _json("normalizer.json", _strings)),
    ("normalizer-empty-object", _json("normalizer.json", lambda d: d.clear())),
]
DYN = _damaged(("model.json", "weights.safetensors", "linear.safetensors")) + [
    ("version-str", _json("model.json", lambda d: d.update(format_version="x"))),
    ("version-list", _json("model.json", lambda d: d.update(format_version=[1]))),
    ("config-list", _json("model.json", lambda d: d.update(config=[1]))),
    ("encoding-str", _json("model.json", lambda d: d.update(encoding="x"))),
    ("encoding-kept-short", _json("model.json", lambda d: d["encoding"].update(kept=[0]))),
    ("encoding-ref-shape", _json("model.json", lambda d: d["encoding"].update(ref_positions=[[1]]))),
    ("encoding-fixed-str", _json("model.json", lambda d: d["encoding"].update(fixed="abc"))),
    ("meta-list", _json("model.json", lambda d: d.update(meta=[1]))),
]


def _variant(made, kind, name, case):
    member, apply = case
    folder = made / f"{kind}-{name}"
    shutil.copytree(made / kind, folder)
    apply(folder / member)
    return folder


def _one_line(capsys, code, *words):
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("softrnn: error:") and "Traceback" not in err
    for w in words:
        assert str(w) in err, err


@pytest.mark.parametrize("name, case", NODE, ids=[n for n, _ in NODE])
def test_a_damaged_node_model_is_one_line(made, name, case, capsys):
    folder = _variant(made, "node", name, case)
    _one_line(capsys, run_cli(["evaluate", str(folder), str(made / "d.h5"), "--quiet"]), folder)
    _one_line(capsys, run_cli(["export", str(folder), "--onnx", str(made / f"{name}.onnx")]), folder)


@pytest.mark.parametrize("name, case", DYN, ids=[n for n, _ in DYN])
def test_a_damaged_whole_model_is_one_line(made, name, case, capsys):
    folder = _variant(made, "dyn", name, case)
    _one_line(capsys, run_cli(["dynamic", "evaluate", str(folder), "--test", str(made / "d.h5")]), folder)
    out = made / f"{name}.h5"
    _one_line(capsys, run_cli(["dynamic", "rollout", str(folder), str(made / "d.h5"), "-o", str(out)]), folder)


def _bad_data(made, tag):
    if tag == "node-model-folder":
        return made / "node"
    if tag == "config-json":
        return made / "node" / "config.json"
    path = made / f"data-{tag}.h5"
    path.write_bytes({"empty": b"", "random": RANDOM}.get(tag, (made / "d.h5").read_bytes()))
    if tag == "truncated":
        _half(path)
    return path


@pytest.mark.parametrize("tag", ["empty", "random", "truncated", "node-model-folder", "config-json"])
def test_a_damaged_or_foreign_data_set_is_one_line(made, tag, capsys):
    path = _bad_data(made, tag)
    _one_line(capsys, run_cli(["evaluate", str(made / "node"), str(path), "--quiet"]), path)
    _one_line(capsys, run_cli(["show", str(path)]), path)
    _one_line(capsys, run_cli(["plot", str(path), "-o", str(made / f"{tag}.png")]), path)
    _one_line(capsys, run_cli(["dynamic", "rollout", str(made / "dyn"), str(path), "-o", str(made / f"r-{tag}.h5")]),
              path)


@pytest.mark.parametrize("given, reader", [("d.h5", ["evaluate", "{model}", "{data}", "--quiet"]),
                                           ("d.h5", ["dynamic", "evaluate", "{model}", "--test", "{data}"]),
                                           ("dyn", ["evaluate", "{model}", "{data}", "--quiet"]),
                                           ("node", ["dynamic", "evaluate", "{model}", "--test", "{data}"])],
                         ids=["data-as-node-model", "data-as-whole-model", "whole-as-node", "node-as-whole"])
def test_a_file_of_another_kind_given_as_a_model_is_one_line(made, given, reader, capsys):
    argv = [a.format(model=made / given, data=made / "d.h5") for a in reader]
    _one_line(capsys, run_cli(argv), made / given)


@pytest.mark.parametrize("content", [b"", b"PK\x03\x04 not a zip", bytes(range(256)) * 2])
def test_a_corrupt_control_model_file_is_one_line(tmp_path, content):
    """``control magnetic --model FILE.npz``: empty, truncated or random bytes give one line naming
    --model, not numpy's EOFError / zipfile's BadZipFile."""
    path = tmp_path / "model.npz"
    path.write_bytes(content)
    with pytest.raises(SoftrnnInputError, match="--model") as err:
        NarxModel.load(path)
    assert "\n" not in str(err.value)
