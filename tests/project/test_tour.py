"""The README's five-minute tour runs as written: every command of its shell block (in this process,
in an empty folder) and its Python block, and each leaves the file it names."""

import re
import shlex
from pathlib import Path

from helpers import run_cli

ROOT = Path(__file__).resolve().parents[2]


def _block(name: str, language: str) -> str:
    text = (ROOT / "README.md").read_text()
    found = re.search(rf"<!-- {name}:begin -->\s*```{language}\n(.*?)```\s*<!-- {name}:end -->", text, re.DOTALL)
    assert found, f"README.md has no {name} block of {language}"
    return found.group(1)


def _commands() -> list[list[str]]:
    """The shell block's commands, comments removed, as argument lists after ``softrnn``."""
    commands = []
    for line in _block("tour", "bash").splitlines():
        words = shlex.split(line, comments=True)
        if words:
            assert words[0] == "softrnn", f"the tour runs only softrnn commands: {line}"
            commands.append(words[1:])
    return commands


def test_the_tour_runs_as_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    commands = _commands()
    assert len(commands) >= 6, "the tour shows simulate, show, plot or animate, train, evaluate and rollout"
    for argv in commands:
        assert run_cli(argv + ["--quiet"] if _takes_quiet(argv) else argv) == 0, f"softrnn {shlex.join(argv)}"
        for i, word in enumerate(argv[:-1]):
            if word in ("-o", "--output", "--figures"):
                assert (tmp_path / argv[i + 1]).exists(), f"softrnn {shlex.join(argv)} wrote no {argv[i + 1]}"


def _takes_quiet(argv: list[str]) -> bool:
    """The tour's commands that show progress bars (kept out of the test's output)."""
    return argv[0] in ("simulate", "animate", "train", "evaluate", "rollout")


def test_the_python_tour_runs_as_written(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    exec(compile(_block("python-tour", "python"), "README.md (python tour)", "exec"), {})
    out = capsys.readouterr().out
    assert "(2001, 51, 3)" in out
