"""``make test`` runs the suite on several pytest-xdist worker processes (``TEST_WORKERS``, 2 by
default; 0 runs it in one process), the ``test`` extra installs pytest-xdist, and CONTRIBUTING.md
shows the command the Makefile runs. Plain text checks of the Makefile, pyproject.toml and the docs."""

import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _make_variables() -> dict[str, str]:
    """The Makefile's ``NAME ?= value`` and ``NAME := value`` assignments."""
    found = {}
    for line in (ROOT / "Makefile").read_text(encoding="utf-8").splitlines():
        m = re.match(r"^([A-Z_]+)\s*(?:\?=|:=|=)\s*(.*?)\s*$", line)
        if m:
            found[m.group(1)] = m.group(2)
    return found


def _recipe(target: str) -> list[str]:
    """The recipe lines of the Makefile's ``target``, without their leading tab."""
    lines = (ROOT / "Makefile").read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if re.match(rf"^{re.escape(target)}:", line))
    recipe = []
    for line in lines[start + 1:]:
        if not line.startswith("\t"):
            break
        recipe.append(line[1:])
    return recipe


def _expanded(text: str, variables: dict[str, str]) -> str:
    """``text`` with each ``$(NAME)`` of the Makefile replaced by its value, repeatedly."""
    for _ in range(5):
        text = re.sub(r"\$\(([A-Z_]+)\)", lambda m: variables.get(m.group(1), m.group(0)), text)
    return text


@pytest.mark.parametrize("target", ["test", "test-all"])
def test_make_test_runs_pytest_on_test_workers_processes_two_by_default(target):
    variables = _make_variables()
    assert variables.get("TEST_WORKERS") == "2", "make test's worker count: TEST_WORKERS ?= 2"
    command = _expanded(" ".join(_recipe(target)), variables)
    assert re.search(r"-m pytest -q -n 2 --dist \w+", command), command
    assert "NUMBA_NUM_THREADS=1" in command and "OMP_NUM_THREADS=1" in command


def test_the_test_extra_installs_pytest_xdist():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    assert any(re.fullmatch(r"pytest-xdist>=[\d.]+", r.replace(" ", "")) for r in extras["test"]), extras["test"]


def test_contributing_shows_the_command_make_test_runs():
    variables = dict(_make_variables(), BIN=".venv/bin")
    command = _expanded(" ".join(_recipe("test")), variables)
    contributing = (ROOT / "CONTRIBUTING.md").read_text(encoding="utf-8")
    assert f"`{command}`" in contributing, f"CONTRIBUTING.md's table of test commands lacks `{command}`"
    assert "TEST_WORKERS=0" in contributing
