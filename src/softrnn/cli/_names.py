"""Names the command line shows before it imports the library: the shipped scenarios, listed in
``softrnn --help`` (``simulate``'s line) and ``softrnn animate --help``. A copy of
``softrnn.scenarios.SCENARIO_NAMES`` (which imports the simulator), kept so that the help prints at
once; tests/cli/test_startup.py checks that the two agree."""

SCENARIO_NAMES = ("ellipse", "ellipse-horizontal", "square", "square-circle", "square-figure8", "square-random",
                  "semicircle", "semicircle-cosine", "tendon-planar", "tendon-planar-sine", "tendon-spatial",
                  "tendon-spatial-sine", "tendon-displacement", "steel-wire", "nitinol-guidewire", "contact-plane",
                  "vessel-guidewire", "contact-capstan", "magnetic-bifurcation")
