"""The package's layout: imports point only downward. Every import arrow between two parts is one
the declared table ``ALLOWED`` permits (imports inside functions too); no import circle between
modules; nothing outside ``softrnn.cli`` imports the command line; an import inside a function
(outside the command line) is one of an optional extra and says so; and docs/guide/layout.md shows
the same table."""

import ast
import difflib
import functools
import re
from pathlib import Path

import softrnn

ROOT = Path(softrnn.__file__).parent


ROOT_PART = "softrnn"
"""The root modules (``errors``, ``files``, ``paper``, ``progress``, ``resume``, ``timing``, the
version) stand together as one part; every other part may import them."""

ALLOWED = {
    "softrnn": set(),
    "softrnn.geometry": {"softrnn"},
    "softrnn.rod": {"softrnn", "softrnn.geometry"},
    "softrnn.io": {"softrnn", "softrnn.geometry", "softrnn.rod"},
    "softrnn.statics": {"softrnn", "softrnn.rod"},
    "softrnn.magnetics": {"softrnn", "softrnn.rod", "softrnn.statics"},
    "softrnn.scenarios": {"softrnn", "softrnn.rod", "softrnn.io", "softrnn.statics", "softrnn.magnetics"},
    "softrnn.figures": {"softrnn", "softrnn.geometry", "softrnn.io"},
    "softrnn.sweeps": {"softrnn", "softrnn.rod", "softrnn.io", "softrnn.scenarios"},
    "softrnn.fitting": {"softrnn"},
    "softrnn.calibration": {"softrnn", "softrnn.rod", "softrnn.scenarios", "softrnn.sweeps", "softrnn.fitting"},
    "softrnn.learned": {"softrnn"},
    "softrnn.learned.node": {"softrnn", "softrnn.io", "softrnn.learned"},
    "softrnn.learned.whole": {"softrnn", "softrnn.geometry", "softrnn.io", "softrnn.learned"},
    "softrnn.experiments": {"softrnn", "softrnn.rod", "softrnn.io", "softrnn.statics", "softrnn.magnetics",
                            "softrnn.scenarios", "softrnn.figures", "softrnn.sweeps", "softrnn.calibration",
                            "softrnn.learned", "softrnn.learned.node", "softrnn.fitting"},
    "softrnn.bench": {"softrnn", "softrnn.rod", "softrnn.io", "softrnn.statics", "softrnn.scenarios",
                      "softrnn.sweeps", "softrnn.learned", "softrnn.learned.node", "softrnn.learned.whole",
                      "softrnn.envs"},
    "softrnn.control": {"softrnn", "softrnn.io", "softrnn.magnetics", "softrnn.figures"},
    # envs: gymnasium environments of a device in a vessel, on the simulator and its obstacles
    "softrnn.envs": {"softrnn", "softrnn.geometry", "softrnn.rod", "softrnn.scenarios", "softrnn.figures",
                     "softrnn.magnetics"},
    # lab -> rod, scenarios: the dynamic physics runs the robot's scenario on its recorded tensions
    "softrnn.lab": {"softrnn", "softrnn.rod", "softrnn.io", "softrnn.scenarios", "softrnn.learned",
                    "softrnn.learned.node", "softrnn.fitting"},
    "softrnn.reproduce": {"softrnn", "softrnn.io", "softrnn.scenarios", "softrnn.figures", "softrnn.sweeps",
                          "softrnn.learned", "softrnn.learned.node", "softrnn.learned.whole", "softrnn.experiments",
                          "softrnn.bench", "softrnn.control", "softrnn.lab"},
    "softrnn.cli": {"softrnn", "softrnn.rod", "softrnn.io", "softrnn.statics", "softrnn.magnetics",
                    "softrnn.scenarios", "softrnn.figures", "softrnn.sweeps", "softrnn.calibration",
                    "softrnn.learned", "softrnn.learned.node", "softrnn.learned.whole", "softrnn.experiments",
                    "softrnn.bench", "softrnn.control", "softrnn.lab", "softrnn.reproduce", "softrnn.fitting"},
}
"""Part -> the parts its modules may import (besides its own). A part is a package, except that the
learned family ``softrnn.learned`` splits into ``node`` (the per-node LSTMs), ``whole`` (the
whole-manipulator model) and the family's shared modules (``softrnn.learned.baselines``,
``horizons``, ``metrics``, ``spans``), which both models may import and which import neither."""

PENDING: set[tuple[str, str]] = set()
"""Arrows (part, imported part) that ``ALLOWED`` forbids and work in progress is removing, tolerated
until it lands (then taken out here). Empty: control -> experiments, figures -> scenarios and
learned.whole -> scenarios are gone."""


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
    """Module -> the softrnn modules it imports (anywhere in its body): a fresh copy of the graph, which
    is read from the sources once per process (``_parsed_graph``)."""
    return {name: set(edges) for name, edges in _parsed_graph().items()}


@functools.cache
def _parsed_graph() -> dict[str, set[str]]:
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


def part_of(module: str) -> str:
    """The part of ``ALLOWED`` a module belongs to: softrnn.rod.kernels -> softrnn.rod,
    softrnn.learned.node.train -> softrnn.learned.node, softrnn.learned.spans -> softrnn.learned,
    softrnn.errors -> softrnn (the root)."""
    parts = module.split(".")
    if len(parts) == 1 or not (ROOT / parts[1]).is_dir():
        return ROOT_PART
    if parts[1] == "learned" and len(parts) > 2 and parts[2] in ("node", "whole"):
        return ".".join(parts[:3])
    return ".".join(parts[:2])


def part_arrows() -> dict[tuple[str, str], list[str]]:
    """(part, part it imports) -> the module imports behind that arrow."""
    arrows: dict[tuple[str, str], list[str]] = {}
    for module, edges in import_graph().items():
        for e in edges:
            if part_of(e) != part_of(module):
                arrows.setdefault((part_of(module), part_of(e)), []).append(f"{module} -> {e}")
    return arrows


def test_every_part_is_declared():
    parts = {part_of(m) for m in import_graph()}
    assert parts - set(ALLOWED) == set(), "a new part: declare what it may import in ALLOWED"
    assert set(ALLOWED) - parts == set(), "ALLOWED names a part that does not exist"
    assert all(imported in ALLOWED for allowed in ALLOWED.values() for imported in allowed)


def test_every_import_arrow_is_declared():
    undeclared = {f"{a} -> {b}": sorted(how) for (a, b), how in part_arrows().items()
                  if b not in ALLOWED[a] and (a, b) not in PENDING}
    assert undeclared == {}


def test_the_declared_parts_form_layers():
    assert _cycles({a: set(b) for a, b in ALLOWED.items()}) == []


def test_the_two_learned_models_do_not_import_each_other():
    node, whole, shared = "softrnn.learned.node", "softrnn.learned.whole", "softrnn.learned"
    assert whole not in ALLOWED[node] and node not in ALLOWED[whole]
    assert shared in ALLOWED[node] and shared in ALLOWED[whole]
    assert node not in ALLOWED[shared] and whole not in ALLOWED[shared]


FORBIDDEN = {("softrnn.learned", "softrnn.rod"), ("softrnn.learned.node", "softrnn.rod"),
             ("softrnn.learned.whole", "softrnn.rod"), ("softrnn.learned", "softrnn.scenarios"),
             ("softrnn.learned.node", "softrnn.scenarios"), ("softrnn.learned.whole", "softrnn.scenarios"),
             ("softrnn.bench", "softrnn.experiments")}
"""Arrows the design forbids, whatever ``ALLOWED`` says: the learned models never stand on the
simulator (its loads or its stepping; the geometry they share with it is ``softrnn.geometry``) nor on
the scenario files, and the benchmarks never on the paper's studies (their load cases live below
both, e.g. ``softrnn.statics.cases``)."""

SIMULATOR = ("softrnn.rod.loads", "softrnn.rod.simulation", "softrnn.scenarios")
"""The modules of the simulator's loads and stepping, and the scenario files."""


def test_the_forbidden_arrows_stay_forbidden():
    assert {(a, b) for (a, b) in FORBIDDEN if b in ALLOWED[a]} == set()
    assert FORBIDDEN & PENDING == set()
    reached = {f"{m} -> {i}" for m, imported in import_graph().items() if part_of(m).startswith("softrnn.learned")
               for i in imported if i.startswith(SIMULATOR)}
    assert reached == set()


def test_pending_arrows_are_still_there():
    """An arrow in PENDING that no longer exists is to be taken out of PENDING."""
    assert PENDING - set(part_arrows()) == set()


def _in_function_imports():
    """(module path, line, source line) of every import inside a function outside ``softrnn.cli``."""
    for path in sorted(ROOT.rglob("*.py")):
        if path.relative_to(ROOT).parts[0] == "cli":
            continue
        lines = path.read_text(encoding="utf-8").splitlines()
        for fn in ast.walk(ast.parse("\n".join(lines))):
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for node in ast.walk(fn):
                    if isinstance(node, (ast.Import, ast.ImportFrom)):
                        yield path, node, lines[node.lineno - 1: node.end_lineno]


def _outside_softrnn(node) -> bool:
    """Whether an import statement imports only modules of other packages (none of softrnn's own)."""
    if isinstance(node, ast.Import):
        return not any(a.name.split(".")[0] == "softrnn" for a in node.names)
    return node.level == 0 and (node.module or "").split(".")[0] != "softrnn"


def test_an_import_inside_a_function_is_an_optional_extra_and_says_so():
    """Imports sit at the top of each module; the only exceptions are the optional extras (PyTorch,
    safetensors, ONNX, ONNX Runtime, Dask, and softrnn modules that import them at their top),
    marked ``# optional extra: ...`` on the line, and a slow import of another package that only one
    path needs (``softrnn.__version__``'s importlib.metadata), marked ``# heavy: ...``; softrnn's own
    modules are never imported inside a function. The command line is exempt: it imports each
    subcommand's parts when that subcommand runs, so that ``softrnn --help`` starts at once
    (tests/cli/test_startup.py checks its modules' tops)."""
    unmarked = [f"{path.relative_to(ROOT)}:{node.lineno} {text[0].strip()}"
                for path, node, text in _in_function_imports()
                if not any("# optional extra:" in line for line in text)
                and not (_outside_softrnn(node) and any("# heavy:" in line for line in text))]
    assert unmarked == []


LAYOUT_PAGE = ROOT.parents[1] / "docs" / "guide" / "layout.md"


def _short(part: str) -> str:
    return "root" if part == ROOT_PART else part.removeprefix("softrnn.")


def test_the_layout_page_shows_the_declared_table():
    """docs/guide/layout.md holds ``ALLOWED`` between ``<!-- allowed-imports -->`` and
    ``<!-- /allowed-imports -->``, one row per part: | `part` | `imported`, `imported`, ... |."""
    text = LAYOUT_PAGE.read_text(encoding="utf-8")
    block = re.search(r"<!-- allowed-imports -->(.*?)<!-- /allowed-imports -->", text, re.S)
    assert block, "docs/guide/layout.md has no marked table of allowed imports"
    shown = {}
    for row in block.group(1).strip().splitlines()[2:]:
        cells = [c.strip() for c in row.strip().strip("|").split("|")]
        shown[cells[0].strip("`")] = set(re.findall(r"`([^`]+)`", cells[1]))
    assert shown == {_short(a): {_short(b) for b in allowed} for a, allowed in ALLOWED.items()}


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


def _builds_kernel(node) -> bool:
    """A kernel's builder: a function that defines a numba kernel (a closure over a cache stamp) and
    returns it; its length is the kernel's."""
    return any(isinstance(s, ast.FunctionDef) and _is_kernel(s) for s in node.body)


def test_no_function_outside_numba_kernels_is_longer_than_80_lines():
    long = []
    for path in ROOT.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not _is_kernel(node) \
                    and not _builds_kernel(node):
                lines = node.end_lineno - node.lineno + 1
                if lines > 80:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({lines} lines)")
    assert long == []


ROOT_MODULES = {"__init__.py", "errors.py", "files.py", "paper.py", "progress.py", "resume.py", "timing.py"}
"""What stays in the package root: what every part uses (errors and validators, atomic file
writing and the JSON encoder, the paper's figures, the progress protocol that rod runs, sweeps,
training, studies, benchmarks and the reproduce pipeline all report through, the settings check
that sweeps, trainings, studies and the reproduce steps resume by) and the version."""


def test_the_package_root_holds_only_what_every_part_uses():
    assert {p.name for p in ROOT.glob("*.py")} <= ROOT_MODULES


# ------------------------------------------------------------------------------------------ the tests' own layout
TESTS = Path(__file__).resolve().parents[1]


def _test_modules() -> list[Path]:
    return sorted(TESTS.rglob("test_*.py"))


def test_no_test_module_imports_another():
    offenders = []
    for path in _test_modules():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{path.relative_to(TESTS)} imports {n}" for n in names
                          if n.split(".")[-1].startswith("test_")]
    assert offenders == []


def test_test_modules_have_distinct_names():
    """Unique file names (pytest's default import mode needs them) and none a near-copy of another's
    (test_output / test_outputs, test_dynamic / test_dynamics): a plural or a slip of a letter or two."""
    names = [p.stem.removeprefix("test_") for p in _test_modules()]
    assert len(names) == len(set(names))
    close = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]
             if a.rstrip("s") == b.rstrip("s") or difflib.SequenceMatcher(None, a, b).ratio() > 0.9]
    assert close == []
