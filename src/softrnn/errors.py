"""Exceptions with one-line, fix-it messages (the CLI prints them and exits with code 2: bad input,
a run that cannot go on, a fault of the machine such as a full disk), and the
validators every part uses to build them (``is_int``, ``integer``, ``finite``, ``positive``,
``nonnegative``, ``vec3``, ``one_line``), and ``store_frozen``, which keeps the arrays a frozen
dataclass checked as its read-only fields."""

import importlib.util
import math
import numbers


class SoftrnnInputError(ValueError):
    """Bad user input: the message names the argument, the value received and the fix."""


class SimulationError(RuntimeError):
    """A run that cannot continue (divergence, Newton failure); the message says why and how to fix it."""


class FileFault(OSError):
    """A fault of the machine, not of the input: a full disk, a vanished or unwritable folder
    (``softrnn.files.write_fault``). One line naming the path, what happened and the fix; what
    was being written is removed, finished work kept. The CLI prints it and exits with code 2. An
    ``OSError`` (``errno`` the system's), as the failed write was before it had a line of its own."""


def bad(argument: str, value, expected: str) -> SoftrnnInputError:
    """Build the standard one-line error: ``argument=value is invalid: expected ...``."""
    return SoftrnnInputError(f"{argument}={value!r} is invalid: {expected}")


# --------------------------------------------------------------------------------------- validators
def one_line(text) -> str:
    """``str(text)`` on one line: every run of white space (newlines included) becomes one space."""
    return " ".join(str(text).split())


def is_int(value) -> bool:
    """True for a Python or numpy integer that is not a bool (numpy registers its integers as
    ``numbers.Integral``, so numpy is not imported here: the CLI starts without it)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def is_finite_number(value) -> bool:
    """True for a finite Python or numpy integer or float that is not a bool."""
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and math.isfinite(value))


def integer(name: str, value, low: int = 1) -> int:
    """``value`` as an ``int`` >= ``low``; a ``SoftrnnInputError`` (``name=value is invalid: an
    integer >= low``) for anything else (bools, floats, strings included)."""
    if not is_int(value) or value < low:
        raise bad(name, value, f"an integer >= {low}")
    return int(value)


def int_items(name: str, value, expected: str) -> tuple:
    """``value`` as a tuple of items: one integer gives ``(value,)``, an iterable other than a
    string its items (not checked here); a ``SoftrnnInputError`` (``expected``) for anything else."""
    items = (value,) if is_int(value) else value
    if isinstance(items, (str, bytes)) or not hasattr(items, "__iter__"):
        raise bad(name, items, expected)
    return tuple(items)


def _in(unit: str) -> str:
    return f" in {unit}" if unit else ""


def finite(name: str, value, unit: str = "") -> float:
    """``value`` (an int or float, not a bool) as a finite ``float``, or a ``SoftrnnInputError``
    naming ``name`` (``... a finite number in unit``)."""
    if not is_finite_number(value):
        raise bad(name, value, f"a finite number{_in(unit)}")
    return float(value)


def positive(name: str, value, unit: str = "") -> float:
    """``value`` (an int or float, not a bool) as a finite ``float`` > 0, or a ``SoftrnnInputError``
    naming ``name`` (``... a positive finite number in unit``)."""
    if not is_finite_number(value) or value <= 0:
        raise bad(name, value, f"a positive finite number{_in(unit)}")
    return float(value)


def nonnegative(name: str, value, unit: str = "") -> float:
    """``value`` (an int or float, not a bool) as a finite ``float`` >= 0, or a ``SoftrnnInputError``
    naming ``name`` (``... a finite number >= 0 in unit``)."""
    if not is_finite_number(value) or value < 0:
        raise bad(name, value, f"a finite number >= 0{_in(unit)}")
    return float(value)


def vec3(name: str, value, what: str = "", *, nonzero: bool = False) -> tuple[float, float, float]:
    """``value`` (a sequence or array of three ints or floats, not bools) as a tuple of three finite
    floats, or a ``SoftrnnInputError`` naming ``name``: ``... a finite 3-vector [x, y, z] what``
    (``nonzero``: also refused when all three are 0, ``a finite, nonzero 3-vector``). ``what`` says
    what the vector is, e.g. ``"in m/s^2, e.g. (0, 0, -9.81)"``."""
    try:
        items = list(value)
    except TypeError:
        items = None
    if items is None or len(items) != 3 or not all(is_finite_number(c) for c in items) \
            or (nonzero and not any(items)):
        kind = "a finite, nonzero 3-vector" if nonzero else "a finite 3-vector"
        raise bad(name, value, f"{kind} [x, y, z]{' ' + what if what else ''}")
    return tuple(float(c) for c in items)



def store_frozen(obj, **arrays) -> None:
    """Set each array of ``arrays`` read-only and store it as the field of that name of the frozen
    dataclass ``obj`` (in ``__post_init__``, after checking them)."""
    for name, a in arrays.items():
        a.setflags(write=False)
        object.__setattr__(obj, name, a)

EXTRAS = {"torch": "learn", "safetensors": "learn", "onnx": "learn", "onnxruntime": "learn",
          "distributed": "dask", "dask": "dask", "gymnasium": "envs", "stable_baselines3": "rl"}
"""Optional packages and the extra of ``softrnn`` that installs each (pyproject.toml)."""


def missing_extra(err: ImportError) -> SoftrnnInputError | None:
    """The one-line error for an import of an optional package that is not installed (None when
    ``err`` is about anything else)."""
    name = (getattr(err, "name", None) or "").split(".")[0]
    extra = EXTRAS.get(name)
    if extra is None:
        return None
    return SoftrnnInputError(f"this needs the optional package {name!r}, which is not installed; install the "
                             f"'{extra}' extra: pip install 'softrnn[{extra}]' (or 'softrnn[all]')")


def require_extra(extra: str) -> None:
    """Raise the one-line ``missing_extra`` error now, before any output is written, when a package
    of the optional ``extra`` ('learn', 'dask', 'envs' or 'rl') is not installed."""
    for name, owner in EXTRAS.items():
        if owner == extra and importlib.util.find_spec(name) is None:
            raise missing_extra(ModuleNotFoundError(f"No module named {name!r}", name=name))
