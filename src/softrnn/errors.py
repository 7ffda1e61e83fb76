"""Exceptions with one-line, fix-it messages (the CLI prints them and exits with code 2)."""


class SoftrnnInputError(ValueError):
    """Bad user input: the message names the argument, the value received and the fix."""


class SimulationError(RuntimeError):
    """A run that cannot continue (divergence, Newton failure); the message says why and how to fix it."""


def bad(argument: str, value, expected: str) -> SoftrnnInputError:
    """Build the standard one-line error: ``argument=value is invalid: expected ...``."""
    return SoftrnnInputError(f"{argument}={value!r} is invalid: {expected}")


EXTRAS = {"torch": "learn", "safetensors": "learn", "onnx": "learn", "onnxruntime": "learn",
          "distributed": "dask", "dask": "dask"}
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
