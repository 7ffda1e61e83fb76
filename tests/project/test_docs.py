"""The documentation site (mkdocs.yml, docs/).

* ``mkdocs build --strict`` passes: every page builds, every link and anchor resolves, every
  ``::: module`` directive of the API reference finds its module (skipped where the docs tools are
  not installed: ``pip install -e '.[docs]'``). No warning is filtered: a docstring that makes one
  (e.g. ``[a] [b]`` read as a link, text after the last parameter without a ``Notes`` heading) fails.
* A missing docstring fails: every public module, class, function and method that an API page in
  the nav documents has a docstring. mkdocstrings hides undocumented objects
  (``show_if_no_docstring: false``), so without this check they would silently vanish from the site.
* Every public module of a documented package is on an API page.

The documented objects come from the ``:::`` lines of the API pages that mkdocs.yml's nav lists, so
the checks follow the package layout as the pages do; nothing here imports softrnn.
"""

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "mkdocs.yml"
DOCS = ROOT / "docs"
SRC = ROOT / "src"

# Public modules of documented packages that are deliberately on no API page.
NOT_ON_API_PAGES: set = set()

_DIRECTIVE = re.compile(r"^:::\s+([A-Za-z_][\w.]*)\s*$")
_NAV_PAGE = re.compile(r"([\w./-]+\.md)\s*$")
_OPTION = re.compile(r"^\s+(\w+):\s*(.*?)\s*$")


def _nav_pages() -> list[str]:
    """The Markdown files that mkdocs.yml's nav lists (not its comments), relative to docs/. Plain
    text parsing: the nav is a YAML block of '- Title: page.md' / '- page.md' lines."""
    pages, in_nav = [], False
    for line in CONFIG.read_text(encoding="utf-8").splitlines():
        if line.startswith("nav:"):
            in_nav = True
            continue
        if in_nav and line.strip() and not line[0].isspace() and not line.startswith("#"):
            break                                   # the next top-level key
        stripped = line.strip()
        if in_nav and stripped and not stripped.startswith("#"):
            m = _NAV_PAGE.search(stripped.split(" #")[0])
            if m:
                pages.append(m.group(1))
    return pages


def _option_value(text: str):
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    if text.startswith("[") and text.endswith("]"):
        return [x.strip().strip("'\"") for x in text[1:-1].split(",") if x.strip()]
    return text


def _directives() -> list[tuple[str, str, dict]]:
    """(page, identifier, options) of every ``::: identifier`` line of the nav's API pages; the
    options are the indented 'key: value' lines under it (members, show_submodules, ...)."""
    found = []
    for page in _nav_pages():
        if not page.startswith("api/"):
            continue
        lines = (DOCS / page).read_text(encoding="utf-8").splitlines()
        for i, line in enumerate(lines):
            m = _DIRECTIVE.match(line)
            if not m:
                continue
            options = {}
            for nxt in lines[i + 1:]:
                if nxt.strip() and not nxt.startswith("    "):
                    break
                opt = _OPTION.match(nxt)
                if opt and opt.group(1) != "options":
                    options[opt.group(1)] = _option_value(opt.group(2))
            found.append((page, m.group(1), options))
    return found


def _module_file(module: str) -> Path | None:
    base = SRC.joinpath(*module.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _resolve(identifier: str) -> tuple[str, Path, list[str]]:
    """identifier -> (module, its file, the object path inside it), e.g. softrnn.rod.simulation.Setup
    -> ("softrnn.rod.simulation", .../simulation.py, ["Setup"])."""
    parts = identifier.split(".")
    for k in range(len(parts), 0, -1):
        path = _module_file(".".join(parts[:k]))
        if path is not None:
            return ".".join(parts[:k]), path, parts[k:]
    raise AssertionError(f"{identifier}: no module of that name under src/")


def _public(name: str) -> bool:
    return not name.startswith("_")


def _is_accessor(node) -> bool:
    """A property's setter or deleter (documented by its getter)."""
    return any(isinstance(d, ast.Attribute) and d.attr in ("setter", "deleter") for d in node.decorator_list)


def _kind(node, in_class: bool) -> str:
    if isinstance(node, ast.Module):
        return "module"
    if isinstance(node, ast.ClassDef):
        return "class"
    names = {d.id if isinstance(d, ast.Name) else getattr(d, "attr", "") for d in node.decorator_list}
    if names & {"property", "cached_property"}:
        return "property"
    return "method" if in_class else "function"


def _missing_in(node, qualname: str, path: Path, members, in_class: bool = False) -> list[str]:
    """Public objects without a docstring: ``node`` itself and, unless members is false, its public
    classes, functions and methods (recursively); ``members`` may list the names to check."""
    missing = []
    if ast.get_docstring(node) is None:
        kind = _kind(node, in_class)
        line = getattr(node, "lineno", 1)
        missing.append(f"{path.relative_to(ROOT)}:{line}: {qualname} ({kind})")
    if members is False or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
        return missing
    for child in node.body:
        if not isinstance(child, (ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        if not _public(child.name) or _is_accessor(child):
            continue
        if isinstance(members, list) and child.name not in members:
            continue
        missing += _missing_in(child, f"{qualname}.{child.name}", path, True, isinstance(node, ast.ClassDef))
    return missing


def _submodules(module: str, path: Path) -> list[tuple[str, Path]]:
    """Public modules inside a package (recursively); none for a plain module."""
    if path.name != "__init__.py":
        return []
    out = []
    for child in sorted(path.parent.iterdir()):
        if not _public(child.name):
            continue
        if child.suffix == ".py":
            out.append((f"{module}.{child.stem}", child))
        elif (child / "__init__.py").is_file():
            sub = f"{module}.{child.name}"
            out.append((sub, child / "__init__.py"))
            out += _submodules(sub, child / "__init__.py")
    return out


def _documented() -> list[tuple[str, Path, list[str], dict]]:
    """(module, file, object path, options) of everything the API pages render, with the
    submodules that ``show_submodules: true`` adds."""
    out = []
    for _page, identifier, options in _directives():
        module, path, obj = _resolve(identifier)
        out.append((module, path, obj, options))
        if not obj and options.get("show_submodules") and options.get("members", True) is not False:
            out += [(m, p, [], options) for m, p in _submodules(module, path)]
    return out


def test_api_pages_document_something():
    targets = _directives()
    assert targets, "no '::: module' lines found on the API pages (docs/api/*.md) that mkdocs.yml's nav lists"
    for page in _nav_pages():
        assert (DOCS / page).is_file(), f"mkdocs.yml's nav lists docs/{page}, which does not exist"


def test_every_documented_object_has_a_docstring():
    missing = []
    for module, path, obj, options in _documented():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        node, qualname = tree, module
        for name in obj:
            node = next((c for c in node.body if isinstance(c, (ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                         and c.name == name), None)
            assert node is not None, f"{module}.{'.'.join(obj)}: not defined in {path.relative_to(ROOT)}"
            qualname = f"{qualname}.{name}"
        missing += _missing_in(node, qualname, path, options.get("members", True))
    missing = sorted(set(missing))
    assert not missing, (f"{len(missing)} public objects on the API pages have no docstring (mkdocstrings hides "
                         "them); add one to each:\n" + "\n".join(missing))


def test_every_public_module_of_a_documented_package_is_on_an_api_page():
    documented = {module for module, _path, _obj, _options in _documented()}
    absent = []
    for module, path, obj, _options in _documented():
        if obj or path.name != "__init__.py":
            continue
        absent += [m for m, _p in _submodules(module, path) if m not in documented and m not in NOT_ON_API_PAGES]
    absent = sorted(set(absent))
    assert not absent, ("public modules missing from the API reference; add a '::: module' line for each to its "
                        "package's page in docs/api/:\n" + "\n".join(absent))


def test_mkdocs_build_strict(tmp_path):
    pytest.importorskip("mkdocs", reason="the docs tools are not installed (pip install -e '.[docs]')")
    pytest.importorskip("material", reason="mkdocs-material is not installed")
    pytest.importorskip("mkdocstrings_handlers.python", reason="mkdocstrings[python] is not installed")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--clean", "-f", str(CONFIG),
         "-d", str(tmp_path / "site")],
        check=False, cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    output = result.stdout + result.stderr
    assert result.returncode == 0, f"mkdocs build --strict failed (exit {result.returncode}):\n{output}"
    assert (tmp_path / "site" / "index.html").is_file(), output
