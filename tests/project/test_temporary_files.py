"""One atomic temporary-file helper (``softrnn.files``): one name scheme, hidden and beside the
output; several outputs renamed together or none; and no other module makes temporary files."""

import re
from pathlib import Path

import pytest

import softrnn
from softrnn.files import atomic_outputs, temporary_path

SRC = Path(softrnn.__file__).parent


def test_a_temporary_file_is_hidden_beside_its_output_with_its_suffix(tmp_path):
    tmp = temporary_path(tmp_path / "sub" / "data.h5")
    assert tmp.parent == tmp_path / "sub" and tmp.exists() and tmp.stat().st_size == 0
    assert tmp.name.startswith(".data.") and tmp.name.endswith(".tmp.h5")


def test_several_outputs_appear_together_or_not_at_all(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    b.write_text("old")
    with pytest.raises(KeyboardInterrupt), atomic_outputs([a, b]) as temps:
        for t in temps:
            Path(t).write_text("new")
        raise KeyboardInterrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.txt"] and b.read_text() == "old"
    with atomic_outputs([a, b]) as temps:
        for t in temps:
            Path(t).write_text("new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt"] and a.read_text() == b.read_text() == "new"


def test_only_softrnn_files_makes_temporary_files():
    makers = re.compile(r"mkstemp|mkdtemp|NamedTemporaryFile|\.part\b")
    found = [f"{p.relative_to(SRC)}:{n}" for p in SRC.rglob("*.py") if p.name != "files.py"
             for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1) if makers.search(line)]
    assert not found, f"temporary files made outside softrnn.files.temporary_path: {found}"
