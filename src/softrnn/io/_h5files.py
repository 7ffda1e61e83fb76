"""Opening HDF5 files: the one place files are opened, one-line errors for bad files."""

from __future__ import annotations

import errno
import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py

from ..errors import FileFault, SoftrnnInputError, one_line
from ..files import CHANGED, FULL, write_fault
from .schema import DatasetError


def _h5open(path, mode: str = "r") -> h5py.File:
    """Open an HDF5 file (the single place files are opened; tests count the bytes read here)."""
    return h5py.File(path, mode)


def _discard(h5file, tmp, failed: bool = False) -> None:
    """Close ``h5file`` (if open) and remove the file ``tmp``. ``failed``: a write into it failed
    (a full disk): HDF5's close would write again, fail, and leave a file that crashes the
    process when it exits (h5py issue 914), so its descriptor is pointed at the null device
    first: the close then writes nowhere, and the file is removed anyway."""
    try:
        if h5file is not None and h5file.id.valid:
            if failed:
                _to_null(h5file.id.get_vfd_handle())
            h5file.close()
    except Exception:  # noqa: BLE001 - best effort while discarding
        pass
    try:
        os.unlink(tmp)
    except FileNotFoundError:
        pass


@contextmanager
def _h5writing(tmp, path) -> Iterator[h5py.File]:
    """The new HDF5 file ``tmp`` (the temporary name of ``path``), open for writing in the block and
    closed after it; a failed write (a full disk) discards it without writing again (``_discard``)
    and raises ``files.write_fault`` naming ``path``; any other error discards it too."""
    f = _h5open(tmp, "w")
    try:
        yield f
        f.flush()           # a full disk fails here, where the file can still be closed
    except (OSError, RuntimeError) as err:
        code = write_errno(err, path)
        _discard(f, tmp, failed=code is not None or isinstance(err, OSError))
        if code is None:
            raise
        raise write_fault(OSError(code, os.strerror(code)), path) from None
    except BaseException:
        _discard(f, tmp)
        raise
    f.close()


def h5_errno(err: BaseException) -> int | None:
    """The system's error number of an HDF5 failure: ``err.errno``, else the ``errno = N`` that
    HDF5 writes into its message (h5py leaves it out of some, e.g. a failed copy); None if neither."""
    code = getattr(err, "errno", None)
    if code is None:
        found = re.search(r"errno = (\d+)", str(err))
        code = int(found.group(1)) if found else None
    return code if code in errno.errorcode else None


def write_errno(err: BaseException, path) -> int | None:
    """The error number of a failed HDF5 write of ``path``: ``h5_errno(err)``, else ENOENT where
    ``path``'s folder is gone (HDF5 gives no number when the folder vanishes as it makes the file)."""
    code = h5_errno(err)
    if code is None and not Path(path).parent.is_dir():
        code = errno.ENOENT
    return code


def _to_null(fd: int) -> None:
    """Point the file descriptor ``fd`` at the null device (writes vanish, reads find nothing)."""
    sink = os.open(os.devnull, os.O_RDWR)
    try:
        os.dup2(sink, fd)
    finally:
        os.close(sink)


class _Reading:
    """Context: open ``path`` for reading and turn every HDF5 failure into a one-line DatasetError."""

    def __init__(self, path):
        self.path = Path(path)
        self.f = None
        self._stat = None

    def __enter__(self) -> h5py.File:
        p = self.path
        if not p.exists():
            raise DatasetError(f"{p}: no such file; check the path")
        if p.is_dir():
            raise DatasetError(f"{p}: is a folder, not a dataset file; pass one .h5 file "
                               f"(softrnn sweep --merge FILE.h5 writes a sweep's files into one)")
        try:
            self._stat = _stat(p)      # a file that changes from here on is told so
            signature = h5py.is_hdf5(str(p))
        except OSError as err:
            raise DatasetError(f"{p}: cannot be read ({one_line(err)})") from None
        if not signature:
            raise DatasetError(f"{p}: not an HDF5 file (no HDF5 signature); softrnn datasets are HDF5 files "
                               f"written by softrnn (DatasetWriter, 'softrnn import-csv')")
        try:
            self.f = _h5open(p, "r")
        except OSError as err:
            raise DatasetError(f"{p}: truncated or corrupt HDF5 file ({_h5_reason(err)}); re-create or "
                               f"re-copy it") from None
        return self.f

    def __exit__(self, exc_type, exc, tb):
        changed = False
        if self.f is not None:
            changed = self._stat is not None and _stat(self.path) != self._stat
            try:
                self.f.close()
            except Exception:  # noqa: BLE001 - the original error matters more
                pass
        if changed and (exc_type is None or issubclass(exc_type, Exception)):
            raise DatasetError(f"{self.path}: {CHANGED}") from None
        if exc_type is not None and _write_failed(exc):
            return False        # a write beside the read failed (a full disk): the writer's to say
        if exc_type is not None and issubclass(exc_type, (OSError, RuntimeError, KeyError)) \
                and not issubclass(exc_type, SoftrnnInputError):
            raise DatasetError(f"{self.path}: truncated or corrupt HDF5 file ({_h5_reason(exc)}); re-create or "
                               f"re-copy it") from None
        return False


def _write_failed(exc) -> bool:
    """Whether ``exc`` is a failed write (a ``FileFault``, or an HDF5 error of a full disk), not a bad read."""
    return isinstance(exc, FileFault) or (isinstance(exc, (OSError, RuntimeError)) and h5_errno(exc) in FULL)


def _stat(path: Path) -> tuple | None:
    """(size, modification time [ns]) of ``path`` (None: gone): a file that changes while it is read
    is told so (``_Reading``)."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_size, st.st_mtime_ns


def _h5_reason(err) -> str:
    text = one_line(err)
    for prefix in ("Unable to synchronously open file ", "Unable to open file ", "Can't synchronously read data ",
                   "Can't read data "):
        if text.startswith(prefix):
            text = text[len(prefix):].strip("()")
    return text
