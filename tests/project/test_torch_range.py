"""The ``learn`` extra's PyTorch requirement is a range, not a pin (a lab with another CUDA build of
torch installs softrnn beside it), and its lower end is sound: every torch API softrnn calls is listed
here with the release that introduced it (PyTorch's documentation), none after the lower end; the
installed torch has them all. ``make test-torch-range`` runs the learned-model tests with the lower
end and the newest release installed (docs/guide/getting-started.md#pytorch-versions)."""

import inspect
import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

SINCE = {
    # version-sensitive: the reason for the lower end
    "torch.serialization.safe_globals": "2.5",        # the context manager (add_safe_globals came in 2.4)
    "torch.onnx.export(dynamo=)": "2.5",              # the keyword that picks the TorchScript exporter
    "torch.load(weights_only=)": "1.13",
    "torch.is_deterministic_algorithms_warn_only_enabled": "1.13",
    "torch.use_deterministic_algorithms(warn_only=)": "1.11",
    "torch.inference_mode": "1.9",
    "torch.nn.utils.clip_grad_norm_": "1.0",
    "torch.optim.AdamW": "1.2",
    "torch.optim.lr_scheduler.CosineAnnealingLR": "1.0",
    "torch.random.fork_rng": "1.0",
    "torch.inf": "1.9",
    "torch.nn.GELU": "1.2",
    "torch.nn.LSTMCell": "1.0",
    "torch.nn.Conv1d": "1.0",
    "torch.nn.GRU": "1.0",
    "torch.nn.init.zeros_": "1.0",
}
"""torch APIs softrnn uses -> the release that introduced them (the keyword, for a keyword)."""

OLD = ("Generator", "Generator.get_state", "Tensor", "are_deterministic_algorithms_enabled", "as_tensor", "bool",
       "cat", "clamp", "cumsum", "equal", "eye", "float32", "from_numpy", "full", "get_num_threads", "isfinite",
       "jit.load", "jit.save", "jit.trace", "load", "manual_seed", "maximum", "mean", "minimum", "nn.LSTM",
       "nn.Linear", "nn.Module", "nn.Parameter", "nn.Sequential", "nn.Tanh", "no_grad", "ones", "onnx.export",
       "optim.Adam", "optim.Optimizer", "randint", "randn", "randperm", "save", "set_num_threads", "stack", "sum",
       "tanh", "tensor", "uint8", "use_deterministic_algorithms", "where", "zeros", "zeros_like", "export")
"""APIs of every torch 2 release (``torch.export``: only named in a comment)."""

API = {**SINCE, **{f"torch.{name}": "2.0" for name in OLD}}


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(p) for p in re.findall(r"\d+", text)[:3])


def _learn_torch() -> str:
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    (torch,) = [r for r in extras["learn"] if re.match(r"torch\b", r)]
    return torch


def test_the_learn_extra_asks_for_a_range_that_holds_the_pinned_release():
    requirement = _learn_torch()
    match = re.fullmatch(r"torch>=([\d.]+),<(\d+)", requirement.replace(" ", ""))
    assert match, f"the learn extra asks for {requirement!r}: a range 'torch>=LOW,<MAJOR', not a pin"
    low, major = _version(match.group(1)), int(match.group(2))
    pins = re.findall(r"^torch==([\d.]+)$", (ROOT / "constraints.txt").read_text(), flags=re.M)
    assert len(pins) == 1, "constraints.txt pins the release the reproduced figures were made with"
    assert low <= _version(pins[0]) and _version(pins[0])[0] < major
    makefile = (ROOT / "Makefile").read_text()
    assert re.search(rf"^TORCH_LOW \?= {re.escape(match.group(1))}\b", makefile, flags=re.M), \
        "make test-torch-range installs the range's lower end"


def test_every_api_softrnn_calls_is_listed_and_none_is_newer_than_the_lower_end():
    low = _version(re.search(r">=([\d.]+)", _learn_torch()).group(1))
    used = set()
    for path in (ROOT / "src").rglob("*.py"):
        text = path.read_text()
        used |= set(re.findall(r"\btorch(?:\.[A-Za-z_]\w*)+", text))
        if "from torch import nn" in text:
            used |= {"torch." + m for m in re.findall(r"(?<![\w.])(nn(?:\.[A-Za-z_]\w*)+)", text)}
    unlisted = sorted(u for u in used if u not in API)
    assert not unlisted, f"torch APIs used but not listed in SINCE or OLD with their first release: {unlisted}"
    newer = {name: since for name, since in API.items() if _version(since) > low}
    assert not newer, f"APIs newer than the lower end of the learn extra: {newer}"


def test_the_installed_torch_has_every_listed_api():
    torch = pytest.importorskip("torch")
    for name in API:
        base, _, keyword = name.partition("(")
        obj = torch
        for part in base.split(".")[1:]:
            obj = getattr(obj, part, None)
            assert obj is not None, f"torch {torch.__version__} has no {base}"
        if keyword:
            assert keyword.rstrip("=)") in inspect.signature(obj).parameters, f"{base} takes no {keyword}"
