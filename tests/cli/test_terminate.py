"""A job stopped by SIGTERM (a scheduler's time limit, ``kill``) cleans up as after Ctrl-C: no
temporary file is left beside the output, no partial output appears, one line says so, exit 143."""

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

TIMEOUT_S = 300


def _command() -> list:
    script = Path(sys.executable).with_name("softrnn")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "softrnn.cli.main"]


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_sigterm_while_writing_leaves_no_temporary_file(tmp_path):
    out = tmp_path / "square.h5"
    # the square's full run (160,001 samples) takes seconds after its file is opened
    proc = subprocess.Popen(_command() + ["simulate", "square", "-o", str(out)], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + TIMEOUT_S
        while not list(tmp_path.glob("*.tmp*")):
            assert proc.poll() is None, "the run ended before its temporary file was seen"
            assert time.monotonic() < deadline, "no temporary file appeared"
            time.sleep(0.02)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=TIMEOUT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143, err
    lines = err.strip().splitlines()
    assert lines and lines[-1].startswith("softrnn: terminated;") and "Traceback" not in err, err
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [], list(tmp_path.iterdir())


def test_a_stop_inside_llvm_is_put_off(monkeypatch):
    """A SIGTERM or Ctrl-C that arrives while numba compiles (llvmlite calling back into Python from
    C) is delivered again a moment later instead of raised there, where the exception would be
    "ignored" (the job running on, exit 0) or leave LLVM half-done (a crash at exit); elsewhere it
    raises at once."""
    import os
    import types

    from softrnn.cli import main as cli_main

    sent = []
    monkeypatch.setattr(cli_main.threading, "Timer",
                        lambda delay, fn, args: types.SimpleNamespace(start=lambda: sent.append((delay, fn, args))))
    space = {}
    exec(compile("import sys\ndef callback(stop, signum):\n    return stop(signum, sys._getframe())\n",
                 "/site-packages/llvmlite/binding/executionengine.py", "exec"), space)
    assert space["callback"](cli_main._stop, signal.SIGTERM) is None
    assert sent == [(cli_main._DEFER_S, os.kill, (os.getpid(), signal.SIGTERM))]
    with pytest.raises(cli_main.Terminated):
        cli_main._stop(signal.SIGTERM, sys._getframe())
    with pytest.raises(KeyboardInterrupt):
        cli_main._stop(signal.SIGINT, sys._getframe())


_LOST = """
import os, signal, sys, time, weakref
from softrnn.cli import main
from softrnn.cli._progress import Terminated

class Thing:
    pass

def callback(ref):
    os.kill(os.getpid(), signal.SIGTERM)
    for _ in range(100000):     # the stop is raised in here, inside the weakref's callback: Python drops it
        pass

try:
    with main.stoppable():
        thing = Thing()
        ref = weakref.ref(thing, callback)
        del thing
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            time.sleep(0.01)
        print("ran on", flush=True)
except Terminated:
    print("terminated", flush=True)
"""


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_a_stop_that_lands_in_a_weakref_callback_still_stops_the_job():
    """SIGTERM handled while Python runs a weakref's callback: the raised stop is printed as "ignored"
    and lost there, so the command delivers it again (``cli.main._lost_stop``) and the job stops."""
    done = subprocess.run([sys.executable, "-c", _LOST], capture_output=True, text=True, timeout=TIMEOUT_S)
    assert done.stdout.strip() == "terminated", done.stdout + done.stderr
    assert "Exception ignored" not in done.stderr, done.stderr
