"""Opening HDF5 files: the one place files are opened, one-line errors for bad files."""

from __future__ import annotations

import os
from pathlib import Path

import h5py

from ..errors import SoftrnnInputError, one_line
from .schema import DatasetError


def _h5open(path, mode: str = "r") -> h5py.File:
    """Open an HDF5 file (the single place files are opened; tests count the bytes read here)."""
    return h5py.File(path, mode)


def _discard(h5file, tmp) -> None:
    try:
        if h5file is not None and h5file.id.valid:
            h5file.close()
    except Exception:  # noqa: BLE001 - best effort while discarding
        pass
    try:
        os.unlink(tmp)
    except FileNotFoundError:
        pass


class _Reading:
    """Context: open ``path`` for reading and turn every HDF5 failure into a one-line DatasetError."""

    def __init__(self, path):
        self.path = Path(path)
        self.f = None

    def __enter__(self) -> h5py.File:
        p = self.path
        if not p.exists():
            raise DatasetError(f"{p}: no such file; check the path")
        if p.is_dir():
            raise DatasetError(f"{p}: is a folder, not a dataset file; pass one .h5 file "
                               f"(softrnn sweep --merge FILE.h5 writes a sweep's files into one)")
        try:
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
        if self.f is not None:
            try:
                self.f.close()
            except Exception:  # noqa: BLE001 - the original error matters more
                pass
        if exc_type is not None and issubclass(exc_type, (OSError, RuntimeError, KeyError)) \
                and not issubclass(exc_type, SoftrnnInputError):
            raise DatasetError(f"{self.path}: truncated or corrupt HDF5 file ({_h5_reason(exc)}); re-create or "
                               f"re-copy it") from None
        return False


def _h5_reason(err) -> str:
    text = one_line(err)
    for prefix in ("Unable to synchronously open file ", "Unable to open file ", "Can't synchronously read data ",
                   "Can't read data "):
        if text.startswith(prefix):
            text = text[len(prefix):].strip("()")
    return text
