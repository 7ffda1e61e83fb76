"""Calibrating a simulator to recorded data (``softrnn calibrate``) with the calibration core
(``softrnn.fitting``, whose names ``fit`` keeps): ``parallel`` (the fit's simulations in this
process or on Dask), ``scenario`` (a scenario file fitted to a dataset)."""
