"""The package's layout: imports point only downward. No import circle between modules (counting
imports inside functions too), and nothing outside ``softrnn.cli`` imports the command line."""

import ast
from pathlib import Path

import softrnn

ROOT = Path(softrnn.__file__).parent


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _resolve(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def import_graph() -> dict[str, set[str]]:
    """Module -> the softrnn modules it imports (anywhere in its body)."""
    files = {_module_name(p): p for p in ROOT.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        edges = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(name, path.name == "__init__.py", node)
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in files else base for a in node.names]
            for t in targets:
                while t and t not in files:
                    t = t.rpartition(".")[0]
                if t.startswith("softrnn") and t != name:
                    edges.add(t)
        graph[name] = edges
    return graph


def _cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_circles():
    assert _cycles(import_graph()) == []


def _package(module: str) -> str:
    """softrnn.rod.kernels -> softrnn.rod; root modules stand for themselves."""
    parts = module.split(".")
    return ".".join(parts[:2])


def test_no_import_circles_between_packages():
    packages: dict[str, set[str]] = {}
    for module, edges in import_graph().items():
        here = _package(module)
        packages.setdefault(here, set()).update(_package(e) for e in edges if _package(e) != here)
    assert _cycles(packages) == []


def test_only_the_command_line_imports_the_command_line():
    offenders = {m: sorted(e for e in edges if e.startswith("softrnn.cli"))
                 for m, edges in import_graph().items() if not m.startswith("softrnn.cli")}
    assert {m: e for m, e in offenders.items() if e} == {}


def _is_kernel(node) -> bool:
    """A numba kernel (``@njit``/``@jit``/``@vectorize``, with or without arguments)."""
    return any("jit" in ast.unparse(d) or "vectorize" in ast.unparse(d) for d in node.decorator_list)


def test_no_function_outside_numba_kernels_is_longer_than_80_lines():
    long = []
    for path in ROOT.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not _is_kernel(node):
                lines = node.end_lineno - node.lineno + 1
                if lines > 80:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({lines} lines)")
    assert long == []


ROOT_MODULES = {"__init__.py", "errors.py", "files.py", "paper.py", "progress.py", "timing.py"}
"""What stays in the package root: what every part uses (errors and validators, atomic file
writing and the JSON encoder, the paper's figures, the progress protocol that rod runs, sweeps,
training, studies, benchmarks and the reproduce pipeline all report through) and the version."""


def test_the_package_root_holds_only_what_every_part_uses():
    assert {p.name for p in ROOT.glob("*.py")} <= ROOT_MODULES
