"""Atomic file writes (a hidden temporary name in the same folder, then rename: ``temporary_path``,
``atomic_output``), the faults of the machine while writing (a full disk, a vanished or unwritable
folder: ``write_fault``, ``writing``; an output too large for the free space: ``check_room``), the
``default=`` of every ``json.dumps`` (``json_default``) and the checks of output paths that every
command makes before any long work (``prepare_output``)."""

import dataclasses
import errno
import hashlib
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from .errors import FileFault, bad


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
    included) every temporary file is removed and the paths are left as they were. An OSError
    about writing them (a full disk, a vanished or unwritable folder) becomes ``write_fault``'s
    one-line ``FileFault`` naming the path (not the temporary name)."""
    paths = [Path(p) for p in paths]
    temps = []
    try:
        for path in paths:
            temps.append(str(temporary_path(path)))
        yield list(temps)
        for tmp, path in zip(temps, paths):
            os.chmod(tmp, umask_mode())
            os.replace(tmp, path)
    except BaseException as err:
        for tmp in temps:
            discard(tmp)
        if isinstance(err, FileFault):      # a writer's own fault about a temporary name: name the path
            text = str(err)
            for tmp, path in zip(temps, paths):
                text = text.replace(tmp, str(path))
            raise FileFault(text) from None
        path = _written(err, paths, temps) if isinstance(err, OSError) else None
        if path is None:
            raise
        raise write_fault(err, path) from None


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
    moved aside first and removed after). An OSError meanwhile (a full disk, ...) removes the
    temporary folder and becomes ``write_fault``'s one-line ``FileFault``; ``folder`` is left as it was."""
    folder = Path(folder)
    with writing(folder, "the folder was left as it was"):
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
                old = Path(tempfile.mkdtemp(prefix=f".{folder.stem}.", suffix=f".old{folder.suffix}",
                                            dir=folder.parent))
                os.rmdir(old)
                os.replace(folder, old)
            os.replace(tmp, folder)
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise


# ------------------------------------------------------------------------------------------ faults
FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})
"""Errors of a full disk, a full quota or a file larger than allowed (``ulimit -f``)."""
DENIED = frozenset({errno.EACCES, errno.EPERM, errno.EROFS})
"""Errors of a folder that cannot be written (permissions, a read-only file system)."""
GONE = frozenset({errno.ENOENT, errno.ENOTDIR, errno.ESTALE})
"""Errors of a folder that vanished (removed, moved, an unmounted disk)."""
KEPT = "no partial file was left"
"""What a failed atomic write leaves: nothing (the end of ``write_fault``'s line)."""


def size_text(n: float) -> str:
    """A byte count in words: ``512 B``, ``1.5 KiB`` .. ``2.3 PiB``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.3g} PiB"  # pragma: no cover


def nearest_folder(path) -> Path:
    """The nearest existing folder at or above ``path`` (absolute)."""
    folder = Path(path).absolute()
    while not folder.is_dir() and folder != folder.parent:
        folder = folder.parent
    return folder


def free_bytes(path) -> int | None:
    """Free bytes on the disk of ``path`` (its nearest existing folder) for this user; None if unknown."""
    try:
        return int(shutil.disk_usage(nearest_folder(path)).free)
    except OSError:
        return None


def write_fault(err: OSError, path, kept: str = KEPT) -> FileFault:
    """The one-line ``FileFault`` for the OSError ``err`` raised while writing ``path``: what
    happened (the system's words for ``err.errno``), the fix (free space, a writable folder, a
    folder that stays) and ``kept``, what was left (default: nothing partial)."""
    path = Path(path)
    code = err.errno
    reason = os.strerror(code) if code else (err.strerror or type(err).__name__)
    folder = nearest_folder(path.parent)
    if code == errno.EFBIG:
        fix = (f"the file system of {folder} or the file-size limit (ulimit -f) allows no larger file; raise the "
               f"limit or choose an output on another disk")
    elif code in FULL:
        free = free_bytes(folder)
        room = "" if free is None else f" ({size_text(free)} free there now)"
        fix = f"free space on the disk of {folder}{room} or choose an output on another disk, and run again"
    elif code in DENIED:
        fix = f"{folder} cannot be written; make it writable or choose an output in a writable folder"
    elif code in GONE:
        fix = (f"the folder {path.parent} was removed or moved while softrnn wrote into it; keep it in place or "
               f"choose another output, and run again")
    else:
        fix = "check the disk (the system log says more) or choose an output on another disk"
    fault = FileFault(f"cannot write {path}: {reason}; {fix}" + (f"; {kept}" if kept else ""))
    fault.errno = code
    return fault


@contextmanager
def writing(path, kept: str = KEPT) -> Iterator[None]:
    """Run the block, which writes ``path``: an OSError with an error number (a full disk, a
    vanished or unwritable folder) becomes ``write_fault(err, path, kept)``."""
    try:
        yield
    except FileFault:
        raise
    except OSError as err:
        if err.errno is None:
            raise
        raise write_fault(err, path, kept) from None


def _written(err: OSError, paths: list, temps: list) -> Path | None:
    """The one of ``paths`` (temporary names ``temps``) that ``err`` is about: by its file name (the
    path, its temporary name, a temporary name being made, its folder) or, without one, any of
    them for a full disk; None when ``err`` is about something else (e.g. a file being read)."""
    if err.errno is None:
        return None
    for name in (err.filename, err.filename2):
        if name is None or not isinstance(name, (str, bytes, os.PathLike)):
            continue
        n = Path(os.fsdecode(name)).absolute()
        for i, path in enumerate(paths):
            p = path.absolute()
            ours = (n == p or n == p.parent or (i < len(temps) and n == Path(temps[i]).absolute())
                    or (n.parent == p.parent and n.name.startswith(f".{p.stem}.")))
            if ours:
                return path
    if err.filename is None and err.errno in FULL and paths:
        return paths[0]
    return None


CHANGED = "changed or truncated while reading; re-run when the writer has finished"
"""What a file that changed while softrnn read it is told (``read_whole``, the HDF5 reader)."""


def read_whole(path) -> bytes:
    """All bytes of the file ``path``, checked not to change while read (its size and modification
    time before and after, and the bytes read against the size); a file that did (another program
    still writing it) raises ``FileFault`` (``path: changed or truncated while reading; ...``)."""
    with open(path, "rb") as fh:
        before = os.fstat(fh.fileno())
        data = fh.read()
        after = os.fstat(fh.fileno())
    if len(data) != before.st_size or (after.st_size, after.st_mtime_ns) != (before.st_size, before.st_mtime_ns):
        raise FileFault(f"{path}: {CHANGED}")
    return data


def check_room(path, need: float, what: str, fix: str, *, least: bool = False) -> None:
    """Refuse up front an output ``path`` that would not fit the free space on its disk: a one-line
    ``FileFault`` (``cannot write PATH: what would take about need bytes, but FOLDER has F free;
    fix``; ``least``: "at least", ``need`` being a lower bound), before any work; nothing when it
    fits or the free space is unknown."""
    free = free_bytes(path)
    if free is None or need <= free:
        return
    raise FileFault(f"cannot write {path}: {what} would take {'at least' if least else 'about'} {size_text(need)}, "
                    f"but {nearest_folder(path)} has {size_text(free)} free; {fix}")


def json_default(value):
    """``json.dumps``'s ``default=`` for everything softrnn writes as JSON: numpy scalars as Python
    numbers, numpy arrays as nested lists, paths as strings, ranges as ``[start, stop]``, sets as
    sorted lists and dataclass instances as dicts (``dataclasses.asdict``); anything else raises
    the ``TypeError`` that ``json.dumps`` expects. Non-finite floats are ``json.dumps``'s to refuse
    (``allow_nan=False``)."""
    np = sys.modules.get("numpy")   # a numpy value exists only once numpy is loaded: the CLI starts without it
    if np is not None and isinstance(value, np.generic):
        return value.item()
    if np is not None and isinstance(value, np.ndarray):
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


def file_sha256(path) -> str:
    """The SHA-256 (hex) of a file's bytes, read a MiB at a time."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
