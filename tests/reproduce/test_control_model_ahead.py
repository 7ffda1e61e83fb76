"""The control step's model identified ahead (``reproduce.control.model_start``, a background process
started while the first steps leave a core idle): the step then reads the very model it would have
trained itself, bit for bit; no process once the step is finished or its model file is there."""

from types import SimpleNamespace

import numpy as np

from softrnn.control import run as control_run
from softrnn.control.run import MODEL_FILE
from softrnn.learned.threads import REPRODUCE_TORCH_THREADS, torch_threads
from softrnn.reproduce import control as rc
from softrnn.reproduce.stepfiles import save_step

TINY = {**rc.QUICK, "identify": 3.0, "train_steps": 5}


def test_the_model_identified_ahead_is_the_one_the_step_would_train(tmp_path, monkeypatch):
    import torch  # noqa: F401  # optional extra: learn (PyTorch)

    monkeypatch.setattr(rc, "QUICK", TINY)
    monkeypatch.setattr(rc.signal, "signal", lambda *a: None)             # the test process keeps its Ctrl-C
    rc._identify(str(tmp_path / "ahead"), True)                           # what the background process runs
    assert (tmp_path / "ahead" / MODEL_FILE).is_file()

    def refused(**kwargs):
        raise AssertionError("identified again although the model file was there")

    with monkeypatch.context() as m:
        m.setattr(control_run, "identified_model", refused)
        ahead = rc._model(tmp_path / "ahead", TINY)                      # read back, not trained
    with torch_threads(REPRODUCE_TORCH_THREADS):
        here = rc._model(tmp_path / "here", TINY)                        # identified and trained in this process
    for name in ("mean", "std", "W1", "b1", "W2", "b2"):
        a, b = getattr(ahead, name), getattr(here, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    drop = lambda meta: {k: v for k, v in meta.items() if k != "seconds"}  # noqa: E731  # a timing
    assert drop(ahead.meta) == drop(here.meta) and ahead.meta["steps"] == TINY["train_steps"]


def test_no_process_once_the_step_is_finished_or_its_model_is_there(tmp_path, monkeypatch):
    started = []

    class Process:
        def __init__(self, target, args, name, daemon):
            started.append((target, args, daemon))

        def start(self):
            started.append("started")

    monkeypatch.setattr(rc.multiprocessing, "get_context", lambda kind: SimpleNamespace(Process=Process))
    assert isinstance(rc.model_start(tmp_path, True), Process)
    assert started == [(rc._identify, (str(tmp_path / "control"), True), True), "started"]
    (tmp_path / "control").mkdir()
    (tmp_path / "control" / MODEL_FILE).write_bytes(b"x")
    assert rc.model_start(tmp_path, True) is None
    (tmp_path / "control" / MODEL_FILE).unlink()
    save_step(tmp_path / "control" / "step.json", {}, True)
    assert rc.model_start(tmp_path, True) is None
    assert rc.model_start(tmp_path / "full", False) is None        # the full run trains it in its own step
