"""User docs describe what softrnn does now (CONTRIBUTING.md): no issue numbers and no history
("used to", "no longer diverges", "an earlier version"). History goes to CHANGELOG.md.

The phrase list is kept specific so that legitimate prose ("the cost no longer decreases", an
algorithm's stopping rule; "used to choose", meaning employed) does not match.
"""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

HISTORY = [                                 # a space stands for any whitespace, line breaks included
    r"\bused to get\b",
    r"\bno longer diverges\b",
    r"\bno longer drifts\b",
    r"\bbefore this\b(?! time)",
    r"\ban earlier version\b",
    r"\bthe earlier run's\b",
    r"\bprevious release\b",
    r"\bthis stop\b",
    r"\bissue #?[1-9][0-9]?\b",
]

_PATTERN = re.compile("|".join(h.replace(" ", r"\s+") for h in HISTORY), re.IGNORECASE)


def _user_docs() -> list[Path]:
    pages = [ROOT / "README.md"] + sorted((ROOT / "docs").rglob("*.md"))
    return [p for p in pages if p.name != "CHANGELOG.md"]


@pytest.mark.parametrize("page", _user_docs(), ids=lambda p: str(p.relative_to(ROOT)))
def test_user_docs_tell_no_history(page):
    text = page.read_text(encoding="utf-8")
    hits = [f"{page.relative_to(ROOT)}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)!r}"
            for m in _PATTERN.finditer(text)]
    assert not hits, "history phrases in user docs (move them to CHANGELOG.md):\n" + "\n".join(hits)


def test_the_phrases_match_what_they_mean():
    assert _PATTERN.search("They used to get an output scale of 1 m")
    assert _PATTERN.search("fixed in issue 12")
    assert _PATTERN.search("the model no longer\n  diverges")
    assert _PATTERN.search("Before this, the model drifted")
    assert not _PATTERN.search("the profile is 0 before this time")
    assert not _PATTERN.search("it stops when the cost no longer decreases")
    assert not _PATTERN.search("is never used to choose")
    assert not _PATTERN.search("issue 100 of the journal")


def test_the_package_names_no_issue_number():
    """Messages, help texts, shipped scenarios and docstrings (the API pages) are user-facing too:
    no tracker words such as "issue 15" (``scenario show --summary`` printed one)."""
    issue = re.compile(HISTORY[-1], re.IGNORECASE)
    files = [p for ext in ("*.py", "*.toml") for p in (ROOT / "src" / "softrnn").rglob(ext)]
    assert len(files) > 100
    hits = [f"{p.relative_to(ROOT)}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)!r}"
            for p in files for text in [p.read_text(encoding="utf-8")] for m in issue.finditer(text)]
    assert not hits, "issue numbers in user-facing text:\n" + "\n".join(hits)
