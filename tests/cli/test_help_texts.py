"""Every command's ``--help`` reads cleanly: exit code 0, no ``%%`` left by argparse (a help string
escaped where nothing formats it, as a description is), and no Python object shown as its repr. And
every ``softrnn.<module>`` path that the examples and the user docs name still exists."""

import argparse
import ast
import importlib.util
import re
from pathlib import Path

import pytest

from softrnn.cli.main import build_parser

from helpers import run_cli

ROOT = Path(__file__).resolve().parents[2]


def _commands(parser, prefix=()):
    """Every command line that has a parser of its own: (), ('simulate',), ('lab', 'benchmark'), ..."""
    yield prefix
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _commands(sub, (*prefix, name))


COMMANDS = list(_commands(build_parser()))
REPR = re.compile(r"<(function|class|bound method|module|built-in)\b| object at 0x")


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: " ".join(c) or "softrnn")
def test_help_exits_0_without_escapes_or_reprs(command, capsys):
    assert run_cli([*command, "--help"]) == 0
    text = capsys.readouterr().out
    assert "usage:" in text
    assert "%%" not in text
    assert not REPR.search(text), REPR.search(text).group(0)


def test_every_subcommand_is_covered():
    top = {c[0] for c in COMMANDS if c}
    assert {"simulate", "evaluate", "calibrate", "lab", "dynamic"} <= top
    assert ("lab", "benchmark") in COMMANDS


# ------------------------------------------------------------------------------------------ module paths in docs
MODULE_PATH = re.compile(r"(?<![\w./-])softrnn(?:\.[A-Za-z_]\w*)+")
FILE_SUFFIXES = {"json", "toml", "csv", "h5", "onnx", "pt", "md", "py", "png"}


def _named_paths() -> dict[str, list[str]]:
    """Dotted ``softrnn.`` paths named in examples/ and docs/ (Markdown) -> where."""
    files = sorted(p for p in (ROOT / "examples").iterdir() if p.is_file()) + sorted((ROOT / "docs").rglob("*.md"))
    found: dict[str, list[str]] = {}
    for path in files:
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for m in MODULE_PATH.finditer(line):
                name = m.group(0)
                if name.rsplit(".", 1)[1] not in FILE_SUFFIXES:     # a file name such as softrnn.json
                    found.setdefault(name, []).append(f"{path.relative_to(ROOT)}:{i}")
    return found


def _top_level_names(origin: str) -> set[str]:
    """Names a module defines at its top (defs, classes, assignments, imports, the keys of a dict
    of lazily imported names), read from its source without importing it."""
    names = set()
    for node in ast.parse(Path(origin).read_text(encoding="utf-8")).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name))
            if isinstance(node.value, ast.Dict):
                names.update(k.value for k in node.value.keys if isinstance(k, ast.Constant))
    return names


def _stale(name: str) -> str | None:
    """None if ``name`` is a module, or a module's top-level name (and what follows it); else why not."""
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        module = ".".join(parts[:k])
        try:
            spec = importlib.util.find_spec(module)
        except ModuleNotFoundError:
            spec = None
        if spec is not None:
            break
    rest = parts[k:]
    if not rest or rest[0] in _top_level_names(spec.origin):
        return None
    return f"{module} has no module or name {rest[0]!r}"


def test_every_module_path_in_the_examples_and_docs_exists():
    found = _named_paths()
    assert "softrnn.experiments.magnetic.lab.write_example_csv" in found     # the scan reaches examples/
    stale = {f"{name} ({', '.join(where)})": why for name, where in found.items() if (why := _stale(name))}
    assert stale == {}
