"""Sweep files and folders: many trajectories in one file (one group each) or in a folder of files."""

from __future__ import annotations

import os
from pathlib import Path

from .. import __version__
from ..errors import bad
from ..files import atomic_output
from ._h5files import _h5writing, _Reading
from .reader import list_groups, read_dataset
from .schema import ACTUATION, CONTACT_FIELDS, FIELDS, SCHEMA_VERSION, SWEEP_PREFIX, DatasetError


def sweep_group_name(index: int) -> str:
    """Name of the ``index``-th trajectory of a sweep file: ``traj-00000``, ``traj-00001``, ..."""
    return f"{SWEEP_PREFIX}{int(index):05d}"


def _h5_files(folder: Path) -> list[Path]:
    """The ``*.h5`` files of ``folder``, sorted, hidden ones (temporary files) left out."""
    return sorted(p for p in folder.glob("*.h5") if not p.name.startswith("."))


def trajectories(path) -> list[tuple[Path, str]]:
    """Every trajectory under ``path`` as (file, group) pairs: a file (single or sweep) or a folder
    of ``*.h5`` files (sorted by name, hidden ones left out; not recursive)."""
    path = Path(path)
    files = _h5_files(path) if path.is_dir() else [path]
    return [(f, g) for f in files for g in list_groups(f)]


def merge_files(paths, out_path) -> None:
    """Combine trajectory files into one sweep file, one group each (``traj-00000``, ... in order).

    Parameters
    ----------
    paths : folder, or sequence of files
        A folder means its ``*.h5`` files sorted by name. Sweep files contribute all their groups.
    out_path : str or Path
        The sweep file, written atomically (not one of the inputs).

    Notes
    -----
    Every input is read and validated first; the chunks are then copied without recompression,
    the optional datasets (``actuation``, the contact loads) included. The root's schema is the
    newest of its groups' (at least ``SCHEMA_VERSION``).
    """
    out_path = Path(out_path)
    if isinstance(paths, (str, os.PathLike)) and Path(paths).is_dir():
        files = _h5_files(Path(paths))
        if not files:
            raise DatasetError(f"{paths}: the folder holds no *.h5 files to merge")
    elif isinstance(paths, (str, os.PathLike)):
        files = [Path(paths)]
    else:
        files = [Path(p) for p in paths]
    if not files:
        raise bad("paths", paths, "a folder of .h5 files or a non-empty list of files")
    if any(f.resolve() == out_path.resolve() for f in files):
        raise bad("out_path", str(out_path), "a file that is not one of the inputs")
    sources, schema = [], SCHEMA_VERSION
    for f in files:
        for g in list_groups(f):
            # full validation before anything is written
            schema = max(schema, read_dataset(f, group=g).attrs["schema_version"])
            sources.append((f, g))
    with atomic_output(out_path) as tmp:
        with _h5writing(tmp, out_path) as out:
            out.attrs["softrnn_schema"] = schema
            out.attrs["softrnn_version"] = __version__
            out.attrs["kind"] = "sweep"
            for i, (f, g) in enumerate(sources):
                with _Reading(f) as src:
                    grp = src[g]
                    dst = out.create_group(sweep_group_name(i))
                    for key, value in grp.attrs.items():
                        if key != "kind":
                            dst.attrs[key] = value
                    for name in ("time", "nodes") + FIELDS + tuple(n for n in (ACTUATION,) + CONTACT_FIELDS
                                                                   if n in grp):
                        src.copy(grp[name], dst, name=name)
