"""Every parameter row of the API reference has its description in the Description column.

The API reference renders a docstring's Parameters, Attributes, Returns, Raises (and the other
tabular sections) as Name | Type | Description tables, parsed with the docstring style of
mkdocs.yml (numpy). Numpy style puts the description on the lines under the entry::

    length : float
        Undeformed length L [m].

A one-line ``length : float    undeformed length L [m]`` entry parses as the type
``float    undeformed length L [m]`` with no description, so the site shows the description in the
Type column and an empty Description. ``mkdocs build --strict`` does not warn about it; this check
fails on every such entry of an object the API pages render (the objects of the ``:::`` lines of the
nav's docs/api/*.md pages, with their public members, and the submodules where
``show_submodules: true``), read statically with griffe as mkdocstrings reads them: nothing here
imports softrnn.

It fails too on a docstring whose free text (outside any section) holds two or more lines that look
like field entries (``length : float  undeformed length [m]``, or ``length: undeformed length [m]``):
without a Parameters or Attributes heading they render as one run-on paragraph, and escape the check
of the tables.
"""

import functools
import re
from pathlib import Path

import pytest

griffe = pytest.importorskip("griffe", reason="the docs tools are not installed (pip install -e '.[docs]')")
yaml = pytest.importorskip("yaml", reason="the docs tools are not installed (pip install -e '.[docs]')")

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "mkdocs.yml"
DOCS = ROOT / "docs"

# Known offenders, as "module.object" paths, skipped by the check: a list to shrink, never to grow.
KNOWN_OFFENDERS: frozenset[str] = frozenset()

# The sections that render as Name | Type | Description tables.
TABLE_SECTIONS = frozenset({"parameters", "other parameters", "attributes", "returns", "yields", "receives",
                            "raises", "warns"})
# Longer than any plausible type ("ndarray (S, N, 3) float64", "dict of str -> ndarray (T,)", ...).
MAX_TYPE_CHARS = 60
# A name entry: "x", "x, y", "*args", "**kwargs".
_NAME = re.compile(r"^\*{0,2}[A-Za-z_]\w*(\s*,\s*\*{0,2}[A-Za-z_]\w*)*$")
# Two or more spaces inside the type, then text: "float    undeformed length L [m]".
_GAP_THEN_TEXT = re.compile(r"\S\s{2,}\S")

# A line of free text that looks like a field entry: "name : ..." or "a, b : ..." (numpy's form, a
# space before the colon), or "name: ..." with a lower-case name; prose labels ("Dask: ...",
# "Progress: ...") start with a capital, and "http://..." has no space after its colon.
_FIELD_LINE = re.compile(r"^\s*(?:\*{0,2}[A-Za-z_]\w*(?:\s*,\s*\*{0,2}[A-Za-z_]\w*)*\s+"
                         r"|\*{0,2}[a-z_]\w*(?:\s*,\s*\*{0,2}[a-z_]\w*)*):\s+\S")
# Fewer such lines than this in a text section are taken for prose.
MIN_FIELD_LINES = 2

_DIRECTIVE = re.compile(r"^:::\s+([A-Za-z_][\w.]*)\s*$")


def _config() -> dict:
    # mkdocs.yml has no custom YAML tags; !!python tags would need mkdocs' own loader
    return yaml.safe_load(CONFIG.read_text(encoding="utf-8"))


def _python_options(config: dict) -> dict:
    for plugin in config.get("plugins", []):
        if isinstance(plugin, dict) and "mkdocstrings" in plugin:
            return plugin["mkdocstrings"]["handlers"]["python"]
    raise AssertionError("mkdocs.yml has no mkdocstrings plugin with a python handler")


def _nav_pages(nav) -> list[str]:
    if isinstance(nav, str):
        return [nav]
    if isinstance(nav, list):
        return [p for item in nav for p in _nav_pages(item)]
    if isinstance(nav, dict):
        return [p for value in nav.values() for p in _nav_pages(value)]
    return []


def _directives(config: dict) -> list[tuple[str, dict]]:
    """(identifier, options) of every ``::: identifier`` line of the nav's API pages."""
    found = []
    for page in _nav_pages(config["nav"]):
        if not page.startswith("api/"):
            continue
        lines = (DOCS / page).read_text(encoding="utf-8").splitlines()
        for i, line in enumerate(lines):
            m = _DIRECTIVE.match(line)
            if not m:
                continue
            block = []
            for nxt in lines[i + 1:]:
                if nxt.strip() and not nxt.startswith("    "):
                    break
                block.append(nxt[4:])
            options = (yaml.safe_load("\n".join(block)) or {}).get("options", {}) if block else {}
            found.append((m.group(1), options or {}))
    return found


@functools.cache
def _load():
    config = _config()
    handler = _python_options(config)
    options = handler.get("options", {})
    paths = [ROOT / p for p in handler.get("paths", ["."])]
    style = options.get("docstring_style", "google")
    return griffe.load("softrnn", search_paths=paths, docstring_parser=griffe.Parser(style),
                       docstring_options=options.get("docstring_options") or None, allow_inspection=False,
                       resolve_aliases=False), options


def _entry_line(docstring, section_title: str, *starts: str) -> int:
    """The file line of an entry: the first line after the section's heading that starts with the first
    of ``starts`` found (else the heading's line, else the docstring's first line)."""
    lines = [line.strip() for line in docstring.value.splitlines()]
    first = next((i for i, line in enumerate(lines) if line.lower() == section_title), 0)
    for start in starts:
        for offset in range(first, len(lines)):
            if start and lines[offset].startswith(start):
                return docstring.lineno + offset
    return docstring.lineno + first


def _from_signature(docstring, name: str, annotation) -> bool:
    """Whether a parameter entry's annotation is the signature's (the entry gave no type)."""
    try:
        parameters = docstring.parent.parameters
    except Exception:                       # no parent, or an object without parameters
        return False
    return annotation is not None and name in parameters and parameters[name].annotation is annotation


def _field_lines(text: str) -> list[str]:
    """The lines of a text section that look like field entries, outside code: fenced blocks
    (```` ``` ```` or ``~~~``), indented blocks (4 spaces or more after a blank line) and doctests."""
    found, fence, indented, previous_blank = [], None, False, True
    for line in text.splitlines():
        stripped = line.strip()
        if fence:
            if stripped.startswith(fence):
                fence = None
            continue
        if stripped.startswith(("```", "~~~")):
            fence = stripped[:3]
            continue
        if not stripped:
            previous_blank = True
            continue
        deep = len(line) - len(line.lstrip()) >= 4
        indented = deep and (indented or previous_blank)
        previous_blank = False
        if indented or stripped.startswith((">>>", "... ")):
            continue
        if _FIELD_LINE.match(line):
            found.append(line)
    return found


def docstring_problems(docstring, where: str) -> list[str]:
    """The table entries of ``docstring`` (a parsed griffe Docstring) that render badly, one message
    each: "WHERE: SECTION entry NAME: what is wrong", where WHERE is ``where`` with the entry's line
    in place of ``{line}`` (e.g. "src/softrnn/rod/spec.py:47 (softrnn.rod.spec.RodSpec)"); and its free
    text, where two or more lines of a text section look like field entries without a heading."""
    problems = []
    for section in docstring.parsed:
        kind = section.kind.value
        if kind == "text":
            fields = _field_lines(section.value)
            if len(fields) >= MIN_FIELD_LINES:
                lines = [text.strip() for text in docstring.value.splitlines()]
                line = docstring.lineno + lines.index(fields[0].strip())
                listed = ", ".join(repr(f.strip()[:40]) for f in fields[:3]) + (", ..." if len(fields) > 3 else "")
                problems.append(f"{where.replace('{line}', str(line))}: free text: {len(fields)} lines look like "
                                f"field entries ({listed}) without a section heading: put them under a Parameters "
                                "(arguments) or Attributes (fields) heading, one 'name : type' line each with the "
                                "description on the next lines, indented")
            continue
        if kind not in TABLE_SECTIONS:
            continue
        for item in section.value:
            name = getattr(item, "name", "") or ""
            annotation = item.annotation
            # text, or an expression where the type parses as one
            type_text = str(annotation or "").strip()
            wrong = []
            if not (item.description or "").strip():
                wrong.append("no description (numpy style: the description goes on the next line, indented)")
            if _from_signature(docstring, name, annotation):
                pass                        # an entry without a type shows the signature's annotation
            elif _GAP_THEN_TEXT.search(type_text):
                wrong.append(f"the type {type_text[:70]!r} swallowed its description")
            elif len(type_text) > MAX_TYPE_CHARS:
                wrong.append(f"the type {type_text[:70]!r}... is longer than a plausible type")
            if name and kind in ("parameters", "other parameters", "attributes") and not _NAME.match(name.strip()):
                wrong.append("the name is not a name (text after the last entry belongs under a Notes heading)")
            if wrong:
                line = _entry_line(docstring, kind, f"{name} :" if name else "", name, type_text[:30])
                label = f"{name!r}" if name else repr(type_text[:40])
                problems.append(f"{where.replace('{line}', str(line))}: {kind} entry {label}: {'; '.join(wrong)}")
    return problems


def _is_public(name: str, filters: list[str]) -> bool:
    keep = True
    for pattern in filters:
        negate = pattern.startswith("!")
        if re.search(pattern[1:] if negate else pattern, name):
            keep = not negate
    return keep


def _rendered(obj, options: dict, filters: list[str], top: bool = True):
    """``obj`` and the members mkdocstrings renders with it (public names; imported ones only when
    exported; submodules only with ``show_submodules``). Classes bring ``__init__`` (merged)."""
    if obj.is_alias:
        try:
            obj = obj.final_target
        except Exception:                   # an external or unresolvable import: not ours to check
            return
    yield obj
    if obj.is_class and "__init__" in obj.members and not obj.members["__init__"].is_alias:
        yield obj.members["__init__"]
    members = options.get("members", None) if top else None
    if members is False or obj.is_function:
        return
    for name, member in obj.members.items():
        if isinstance(members, list):
            if name not in members:
                continue
        elif not _is_public(name, filters):
            continue
        if member.is_alias and not member.is_public:
            continue
        if member.is_module and not options.get("show_submodules", False):
            continue
        yield from _rendered(member, options, filters, top=False)


def _all_problems() -> tuple[int, list[str]]:
    """(how many documented objects have a docstring, the problems of their docstrings)."""
    config = _config()
    package, defaults = _load()
    filters = defaults.get("filters", [])
    seen, problems, checked = set(), [], 0
    for identifier, options in _directives(config):
        obj = package.modules_collection[identifier]
        for member in _rendered(obj, {**defaults, **options}, filters):
            if member.path in seen:
                continue
            seen.add(member.path)
            if member.docstring is None or member.path in KNOWN_OFFENDERS:
                continue
            where = f"{Path(member.filepath).relative_to(ROOT)}:{{line}} ({member.path})"
            problems += docstring_problems(member.docstring, where)
            checked += 1
    return checked, problems


def test_every_table_entry_of_the_api_reference_has_a_description():
    checked, problems = _all_problems()
    assert checked > 100, f"only {checked} documented objects found: is the API reference's walk broken?"
    assert not problems, (
        f"{len(problems)} docstring entries render without a description in the API reference. Numpy style: "
        "'name : type' on one line, the description on the next lines, indented 4 more:\n" + "\n".join(problems))


def test_known_offenders_are_documented_objects():
    package, _defaults = _load()
    for path in KNOWN_OFFENDERS:
        assert path in package.modules_collection, f"KNOWN_OFFENDERS names {path}, which does not exist"


def _parsed(text: str, signature: str = "def f(length: float, n_nodes: int): ..."):
    """A function ``f`` with ``signature`` and ``text`` as its docstring, parsed as the site parses it."""
    config = _config()
    style = _python_options(config).get("options", {}).get("docstring_style", "google")
    module = griffe.visit("sample", Path("sample.py"), f'{signature.replace(": ...", ":")}\n    """{text}"""\n',
                          docstring_parser=griffe.Parser(style))
    return module["f"].docstring


def test_the_check_fails_on_a_one_line_entry():
    bad = _parsed("""Bad.

    Parameters
    ----------
    length : float      undeformed length L [m]
    n_nodes : int       number of nodes
    """)
    problems = docstring_problems(bad, "sample.py:{line} (sample.f)")
    assert len(problems) == 2, problems
    assert problems[0].startswith("sample.py:6 (sample.f): parameters entry 'length'"), problems
    assert "swallowed its description" in problems[0]


def test_the_check_fails_on_a_missing_description_and_text_after_the_last_entry():
    bad = _parsed("""Bad.

    Parameters
    ----------
    length : float
    n_nodes : int
        Number of nodes.

    Returns
    -------
    float
        The mass [kg].

    Raises
    ------
    ValueError    when n_nodes < 2
    """)
    problems = docstring_problems(bad, "s:{line}")
    assert [p.split(":")[1] for p in problems] == ["6", "17"], problems
    assert "no description" in problems[0] and "'ValueError" in problems[1], problems

    trailing = _parsed("""Bad.

    Attributes
    ----------
    length : float
        Length [m].
    Standard deviations are floored.
    """, signature="class f: ...")
    assert any("not a name" in p for p in docstring_problems(trailing, "s:{line}"))


def test_the_check_takes_a_long_annotation_from_the_signature():
    sig = "def f(pred_fn: 'Callable[[np.ndarray, np.ndarray, int, int], np.ndarray] | None' = None): ..."
    good = _parsed("""Good.

    Parameters
    ----------
    pred_fn
        A free-running predictor.
    """, signature=sig)
    assert docstring_problems(good, "s:{line}") == []


def test_the_check_passes_numpy_style():
    good = _parsed("""Good.

    Parameters
    ----------
    length : float
        Undeformed length L [m].
    n_nodes : int
        Number of nodes n >= 2 (n - 1 segments).

    Returns
    -------
    mass : ndarray (n,) float64
        Node masses [kg].

    Raises
    ------
    SoftrnnInputError
        When n_nodes < 2.
    """)
    assert docstring_problems(good, "s:{line}") == []


def test_the_check_fails_on_field_entries_without_a_heading():
    bad = _parsed("""Bad.

    length : float    undeformed length L [m]
    n_nodes : int     number of nodes
    """)
    problems = docstring_problems(bad, "s:{line}")
    assert len(problems) == 1, problems
    assert problems[0].startswith("s:4: free text: 2 lines look like field entries"), problems

    colons = _parsed("""Bad.

    length: undeformed length L [m]
    rms_deg, max_deg : over both angles [deg]
    """)
    assert len(docstring_problems(colons, "s:{line}")) == 1


def test_the_check_passes_prose_and_code_that_look_like_fields():
    good = _parsed("""Good: one ``key : value`` line alone is prose.

    length : the undeformed length L [m], written once in a sentence.

    Dask: a ``LocalCluster`` by default, or an existing cluster (``tcp://HOST:PORT``).
    Progress: ``progress(done, total)`` after every step.
    See https://example.org/a and
    https://example.org/b for more.

    ```yaml
    rod:
      length: 0.05
      n_nodes: 26
    ```

    An indented block::

        length : float
        n_nodes : int

    >>> f(length=0.05, n_nodes=26)
    """)
    assert docstring_problems(good, "s:{line}") == []
