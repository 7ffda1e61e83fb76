"""softrnn: real-time dynamic models of soft continuum manipulators."""


def __getattr__(name):
    """``softrnn.__version__``, looked up on first use: ``softrnn --help`` starts without it."""
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version  # heavy: tens of ms, the version only

        try:
            value = version("softrnn")
        except PackageNotFoundError:  # running from a source tree without installation
            value = "0.0.0+unknown"
        globals()["__version__"] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
