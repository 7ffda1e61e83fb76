"""Exceptions with one-line, fix-it messages (the CLI prints them and exits with code 2)."""


class SoftrnnInputError(ValueError):
    """Bad user input: the message names the argument, the value received and the fix."""


class SimulationError(RuntimeError):
    """A run that cannot continue (divergence, Newton failure); the message says why and how to fix it."""


def bad(argument: str, value, expected: str) -> SoftrnnInputError:
    """Build the standard one-line error: ``argument=value is invalid: expected ...``."""
    return SoftrnnInputError(f"{argument}={value!r} is invalid: {expected}")
