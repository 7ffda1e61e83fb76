"""The magnetic experiment of paper section 5 rebuilt in simulation (``experiment``: Table 1,
Fig. 12) and the same comparison on lab CSV recordings (``lab``).

Modules: ``config`` (``ExperimentConfig``), ``currents`` (the coil currents), ``dataset`` (the
LSTMs' data: orientations and magnet wrenches), ``static`` (the static Cosserat model's
predictions), ``comparison`` (LSTM training and Table 1), ``figure`` (Fig. 12), ``run``
(``run_experiment``), ``lab`` (lab CSV data); ``experiment`` gathers their public names. The
camera model is ``softrnn.magnetics.camera``."""
