"""Calibrating a simulator to recorded data (``softrnn calibrate``): ``fit`` (bounded least squares with
parallel finite differences), ``parallel`` (in this process or on Dask), ``scenario`` (a scenario
file fitted to a dataset)."""
