"""Commands refuse a run too large for this machine up front: exit 2, one ``softrnn: error:`` line
naming the flag, nothing written, and fast (``check_run_size``)."""

import time

import pytest

from helpers import run_cli

CASES = {
    "lab-example --duration": (["lab-example", "-o", "{out}", "--duration", "1e9", "--quiet"], "--duration"),
    "lab-example --rate": (["lab-example", "-o", "{out}", "--rate", "1e9", "--quiet"], "--duration"),
    "control magnetic --duration": (["control", "magnetic", "--reference", "step", "--controller",
                                     "static-inverse", "--duration", "1e9", "-o", "{out}", "--quiet"], "--duration"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_too_large_refused_up_front(case, tmp_path, capsys):
    """An absurd duration or rate is refused in one line naming the flag, before any output."""
    argv, flag = CASES[case]
    out = tmp_path / "out"
    start = time.perf_counter()
    code = run_cli([a.replace("{out}", str(out)) for a in argv])
    elapsed = time.perf_counter() - start
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("softrnn: error:") and flag in err[0], err
    assert "too large" in err[0]
    assert not out.exists()
    assert elapsed < 5.0
