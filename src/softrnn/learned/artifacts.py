"""Model folders of every trainable model: the folder error, opening a folder, its JSON files.

A trained model is a folder of a few files (the node model's: ``softrnn.learned.node.artifact``;
the whole-manipulator model's: ``softrnn.learned.whole.artifact``), written atomically and read
back with every file checked. What is wrong with one is a one-line ``ModelFolderError``:
``<folder>: <file> what is wrong; what to do``. This module holds what the two kinds share:
the error, the checks of the folder itself, the format entry of its JSON header, reading and
writing its JSON files and the records in them (``from_fields``), and telling its own files from
foreign ones. The description an export
stores (``export_header``) starts with the same three entries for every kind.
"""

from __future__ import annotations

import json
from pathlib import Path

from .. import __version__
from ..errors import SoftrnnInputError, bad, one_line
from ..files import json_default

AGAIN = "train the model again"
"""What to do about a damaged model folder."""


class ModelFolderError(SoftrnnInputError):
    """A model folder that cannot be used; one line: ``<folder>: <file> what is wrong; what to do``."""


def open_folder(folder, *, made_by: str, train: str) -> Path:
    """``folder`` as a Path after checking that it is an existing folder.

    Parameters
    ----------
    folder : str or Path
        The model folder.
    made_by : str
        The command that writes such folders, quoted (``'softrnn train'``).
    train : str
        The command line that would make the missing folder.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ModelFolderError(f"{folder}: is a file, not a model folder (a folder written by {made_by})")
    if not folder.is_dir():
        raise ModelFolderError(f"{folder}: no such model folder; train one with {train}")
    return folder


def read_json(folder: Path, name: str):
    """The JSON value of file ``name`` in ``folder``; a missing or unreadable file is a ``ModelFolderError``."""
    path = folder / name
    if not path.is_file():
        raise ModelFolderError(f"{folder}: {name} is missing; the model folder is incomplete, {AGAIN}")
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise ModelFolderError(f"{folder}: {name} is corrupt ({one_line(err)[:200]}); {AGAIN}") from None


def write_json(path: Path, value, indent: int = 2) -> None:
    """Write ``value`` as JSON (no NaN or infinity) to ``path``, a file of a folder being written."""
    try:
        text = json.dumps(value, indent=indent, allow_nan=False, default=json_default)
    except (TypeError, ValueError) as err:
        raise bad(path.stem, "...", f"JSON-serialisable values without NaN/inf ({one_line(err)})") from None
    path.write_text(text + "\n")


def write_tensors(path: Path, tensors: dict, metadata: dict | None = None) -> None:
    """Write ``tensors`` (name -> torch tensor) as a safetensors file at ``path``, a file of a folder
    being written: serialised in memory, then written by Python, so that a full disk is the
    ``OSError`` the folder's writer turns into one line (``files.atomic_folder``), not the library's
    own error."""
    from safetensors.torch import save  # optional extra: learn (safetensors)

    path.write_bytes(save(tensors, metadata=metadata))


def check_format(folder: Path, name: str, doc, fmt: str, newest: int, *, what: str, made_by: str,
                 unversioned: bool = False) -> dict:
    """``doc`` (the JSON header ``name`` of ``folder``) checked to be ``{"format": fmt, "format_version":
    v, ...}`` with an integer v <= ``newest``; ``unversioned``: a header without ``format_version``
    is of version 0 (the first files had none). ``what``: the kind of model in words."""
    if not isinstance(doc, dict) or doc.get("format") != fmt:
        found = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
        raise ModelFolderError(f"{folder}: {name} is not a softrnn {what}'s (format={found!r}, expected {fmt!r}); "
                               f"pass a folder written by {made_by}")
    version = doc.get("format_version", 0 if unversioned else None)
    if not isinstance(version, int) or isinstance(version, bool) or version < (0 if unversioned else 1):
        raise ModelFolderError(f"{folder}: {name} has format_version={version!r}, expected an integer "
                               f"(1 to {newest}); {AGAIN}")
    if version > newest:
        raise ModelFolderError(f"{folder}: {name} has format_version {version}, newer than this softrnn reads "
                               f"({newest}); upgrade softrnn")
    return doc


def from_fields(cls, d, name: str, tuples=()):
    """``cls(**d)`` of the dict ``d`` read from a model folder's JSON (the keys in ``tuples`` as tuples);
    anything but a dict of ``cls``'s fields is a one-line error naming ``name``."""
    if not isinstance(d, dict):
        raise bad(name, type(d).__name__, f"a dict of {cls.__name__} fields")
    try:
        return cls(**{k: tuple(v) if k in tuples and v is not None else v for k, v in d.items()})
    except TypeError as err:
        raise bad(name, sorted(d), f"the {cls.__name__} fields ({err})") from None


def foreign_files(folder, ours) -> list[str]:
    """The sorted names in ``folder`` (None: it does not exist) that are neither in ``ours`` nor hidden."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    return sorted(p.name for p in folder.iterdir() if not p.name.startswith(".") and p.name not in set(ours))


def export_header(fmt: str, version: int) -> dict:
    """The first entries of an exported model's description: ``format``, ``format_version``, ``softrnn_version``."""
    return {"format": fmt, "format_version": version, "softrnn_version": __version__}
