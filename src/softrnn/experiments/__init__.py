"""Experiments that combine the parts: the simulated magnetic experiment of paper section 5
(``experiments.magnetic``: the steered rod, the camera, static predictions, LSTMs, Table 1) and the
static solver's timing study of paper Fig. 13 (``experiments.fig13``), the node models' size study
of paper Fig. 14 (``experiments.fig14``), and lab-like recordings of the simulated three-tendon arm
for the lab workflow (``experiments.lab_example``). They stand above
the parts they use (rod, statics, magnetics, learned)."""
