"""Atomic file writes (a hidden temporary name in the same folder, then rename: ``temporary_path``,
``atomic_output``), the ``default=`` of every
``json.dumps`` (``json_default``) and the checks of output paths that every command makes before
any long work (``prepare_output``)."""

import dataclasses
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .errors import bad


def umask_mode() -> int:
    """Permission bits a newly created file gets under the current umask (0o666 & ~umask):
    temporary files from mkstemp are 0o600 and keep that mode after the rename otherwise."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def temporary_path(path) -> Path:
    """Create an empty temporary file beside ``path`` and return its name: hidden, in the same
    folder, ending in the same suffix (``.STEM.XXXXXXXX.tmp.SUFFIX``, the one name scheme of every
    temporary file softrnn writes), with the usual permissions. The folder is created if missing."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}", dir=path.parent)
    os.close(fd)
    os.chmod(tmp, umask_mode())
    return Path(tmp)


def discard(tmp) -> None:
    """Remove the temporary file ``tmp`` if it is there."""
    Path(tmp).unlink(missing_ok=True)


@contextmanager
def atomic_outputs(paths) -> Iterator[list]:
    """Yield one ``temporary_path`` (str) beside each of ``paths`` to write into; when the block
    ends normally each is renamed onto its path (``os.replace``), when it raises (Ctrl-C
    included) every temporary file is removed and the paths are left as they were."""
    temps = []
    try:
        for path in paths:
            temps.append(str(temporary_path(path)))
        yield list(temps)
        for tmp, path in zip(temps, paths):
            os.chmod(tmp, umask_mode())
            os.replace(tmp, path)
    except BaseException:
        for tmp in temps:
            discard(tmp)
        raise


@contextmanager
def atomic_output(path) -> Iterator[str]:
    """Yield a ``temporary_path`` (str) beside ``path`` to write into, renamed onto ``path`` when
    the block ends normally and removed when it raises (``atomic_outputs`` of one path)."""
    with atomic_outputs([path]) as (tmp,):
        yield tmp


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the whole new one."""
    with atomic_output(path) as tmp, open(tmp, "wb") as fh:
        fh.write(data)


def atomic_write_text(path, text: str) -> None:
    """Write ``text`` to ``path`` as UTF-8, atomically (``atomic_write_bytes``)."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_folder(folder, write) -> None:
    """Make ``folder`` appear whole: ``write(tmp)`` fills a temporary folder beside it (named as
    ``temporary_path`` names files), which is then renamed onto ``folder`` (an existing one is
    moved aside first and removed after)."""
    folder = Path(folder)
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.stem}.", suffix=f".tmp{folder.suffix}", dir=folder.parent))
    try:
        mode = umask_mode()
        os.chmod(tmp, mode | ((mode & 0o444) >> 2))  # a folder's mode under the umask (0o755 for 022)
        write(tmp)
        for p in tmp.iterdir():
            os.chmod(p, mode)
        old = None
        if folder.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{folder.stem}.", suffix=f".old{folder.suffix}", dir=folder.parent))
            os.rmdir(old)
            os.replace(folder, old)
        os.replace(tmp, folder)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def json_default(value):
    """``json.dumps``'s ``default=`` for everything softrnn writes as JSON: numpy scalars as Python
    numbers, numpy arrays as nested lists, paths as strings, ranges as ``[start, stop]``, sets as
    sorted lists and dataclass instances as dicts (``dataclasses.asdict``); anything else raises
    the ``TypeError`` that ``json.dumps`` expects. Non-finite floats are ``json.dumps``'s to refuse
    (``allow_nan=False``)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, range):
        return [value.start, value.stop]
    if isinstance(value, (set, frozenset)):
        return sorted(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


# ------------------------------------------------------------------------------------------ outputs
_OVERWRITE = "pass --overwrite to replace it, or choose another path"


def _os_reason(err: OSError) -> str:
    """'Permission denied: /x/y' from an OSError (one line)."""
    what = err.strerror or type(err).__name__
    where = err.filename if err.filename is not None else None
    return f"{what}: {where}" if where is not None else what


def _visible(folder: Path) -> list:
    """Names in ``folder`` other than hidden ones (temporary files are hidden)."""
    return sorted(p.name for p in folder.iterdir() if not p.name.startswith("."))


def _shown(names) -> str:
    names = list(names)
    return ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else "")


def _check_parent(path: Path, argument: str) -> None:
    """The nearest existing folder above ``path`` must be a folder this process may write into."""
    folder = path.absolute().parent
    while not os.path.lexists(folder) and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise bad(argument, str(path), f"a path inside a folder, but {folder} is a file, not a folder; choose "
                                       f"another path")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise bad(argument, str(path), f"a path in a writable folder, but {folder} is not writable (permission "
                                       f"denied); choose another path")


def prepare_output(path, argument: str, *, kind: str = "file", overwrite: bool = False, holds=None,
                   mine=(), fix: str = _OVERWRITE) -> Path:
    """Check, before any long work, that ``path`` can be written as the output named ``argument``
    (e.g. ``"-o"``); raise ``SoftrnnInputError`` (one line: the argument, the path, the fix) if not.
    Creates and changes nothing (the writers create missing parent folders themselves).

    kind="file":   ``path`` must not be a folder; an existing file is refused unless ``overwrite``.
    kind="folder": ``path`` must be a folder or not exist. Unless ``overwrite``, refused when it
                   already holds one of the names in ``holds`` (None: anything but hidden files).
                   ``mine``: names of which a non-empty existing folder must hold at least one (a
                   resumable command's own folder; refused even with ``overwrite`` otherwise).
    In both cases the nearest existing folder above ``path`` must be a writable folder. Any
    OSError (NotADirectoryError, PermissionError, ...) becomes the one-line error. ``fix`` is the
    advice given for an existing output. Returns ``Path(path)``.
    """
    if kind not in ("file", "folder"):
        raise bad("kind", kind, "'file' or 'folder'")
    p = Path(path)
    try:
        if kind == "file":
            if p.is_dir():
                raise bad(argument, str(p), "a file path, but it is a folder; choose a file name")
            if os.path.lexists(p) and not overwrite:
                raise bad(argument, str(p), f"a new file, but it exists; {fix}")
            _check_parent(p, argument)
            return p
        if os.path.lexists(p) and not p.is_dir():
            raise bad(argument, str(p), "a folder, but it exists and is a file; choose another path")
        if not p.is_dir():
            _check_parent(p, argument)
            return p
        names = _visible(p)
        if mine and names and not set(mine) & set(names):
            raise bad(argument, str(p), f"a new or empty folder, or one this command wrote (holding "
                                        f"{' or '.join(mine)}), but it holds other files ({_shown(names)}); "
                                        f"choose another folder")
        if not overwrite:
            found = names if holds is None else [n for n in holds if n in names]
            if found:
                raise bad(argument, str(p), f"a folder without earlier output, but it holds {_shown(found)}; {fix}")
        if not os.access(p, os.W_OK | os.X_OK):
            raise bad(argument, str(p), "a writable folder, but it is not writable (permission denied); choose "
                                        "another folder")
        return p
    except OSError as err:
        raise bad(argument, str(p), f"a path that can be written ({_os_reason(err)}); choose another "
                                    f"path") from None
