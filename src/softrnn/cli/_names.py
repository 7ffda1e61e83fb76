"""Names the command line shows before it imports the library, so that ``softrnn --help`` and each
command's ``--help`` print at once: copies of library constants whose modules import numba, SciPy or
Matplotlib. tests/cli/test_startup.py checks that each equals its source (named beside it)."""

SCENARIO_NAMES = ("ellipse", "ellipse-horizontal", "square", "square-circle", "square-figure8", "square-random",
                  "semicircle", "semicircle-cosine", "tendon-planar", "tendon-planar-sine", "tendon-spatial",
                  "tendon-spatial-sine", "tendon-displacement", "steel-wire", "nitinol-guidewire", "contact-plane",
                  "vessel-guidewire", "contact-capstan", "magnetic-bifurcation", "vessel-guidewire-twist",
                  "mesh-arch-guidewire", "mesh-arch-guidewire-1m")
"""``softrnn.scenarios.scenario.SCENARIO_NAMES``: the shipped scenarios (``simulate``, ``animate``)."""

INTEGRATORS = ("explicit", "implicit")
"""``softrnn.rod.simulation.INTEGRATORS`` (``simulate --integrator``)."""

STYLES = ("auto", "plain", "fluoroscopy")
"""``softrnn.figures.animation.STYLES`` (``animate --style``)."""

CONTROLLERS = ("static-inverse", "mpc-learned", "mpc-physics")
"""``softrnn.control.controllers.CONTROLLERS`` (``control magnetic --controller``)."""

REFERENCES = ("step", "sine", "random")
"""``softrnn.control.references.REFERENCES`` (``control magnetic --reference``)."""

FAMILIES = ("physics", "learned_map", "hybrid", "sequence", "node_lstm")
"""``softrnn.lab.benchmark.FAMILIES`` (``lab benchmark --families``)."""

AUTO_LAGS = 5
"""``softrnn.lab.recording.AUTO_LAGS`` (``import-csv --lag auto``)."""
