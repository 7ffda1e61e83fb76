"""The paper's magnetic experiment, simulated (Tariverdi et al. 2021, section 5, Table 1, Fig. 12).

The dynamic Cosserat model of ``softrnn.magnetics`` plays the real robot, with parameters a few
percent off the nominal ones (``ExperimentConfig``: stiffer rubber, weaker magnets, more damping),
driven by smooth random coil currents. A camera-like measurement samples its centreline, adds
pixel-level noise, fits a polynomial P(s) per coordinate and reads each magnet's orientation from
the fit's tangent at the magnet (paper section 5.2):

    phi_m = acos(z . unit(dP/ds(s_m))),   k_m = unit(z x dP/ds(s_m)),

reported as the rotation vector phi_m k_m [deg] (the rotation taking z to the tangent), whose x, y
and z components are the orientations "about x, y and z" of Table 1. The motion is mostly in the
vertical xz-plane, so the large angle is about y, the bending axis; k_m is perpendicular to z by
construction, so the z component is identically zero (``ORIENTATION_NOTE``).

Two models predict the measured orientations of the last 40 % of the samples:

* the static Cosserat model (``softrnn.statics``) with the nominal parameters, from the coil currents
  alone (``static_predictions``: B and G at the magnets by fixed-point iteration on their positions);
* one LSTM per magnet (paper Fig. 11; ``softrnn.learned.node``): input I the measured orientations of
  both magnets, input II the magnet's wrench [f, tau] computed, as the paper did, from the measured
  magnet pose, the nominal magnet moment and the currents; history 2; trained on the first 60 %;
  evaluated one step ahead (as Table 1) and free running.

``run_experiment`` writes the real robot's record (``robot.h5``, resumable), the two model folders,
``table1.json`` and ``fig12.png`` and returns the report (errors as [[max, mean] per axis x, y, z]
in degrees beside the paper's). ``compare`` is the comparison alone, shared with lab data
(``softrnn.experiments.magnetic.lab``).

Progress: ``progress(done, total, {"stage": stage})`` (``softrnn.progress.Progress``) with stage one of
``STAGES``; the training stages pass the training's details too. The simulations (``simulate``, the
real robot; ``predict``, the calibrated model over the record) count samples, reported every block
of a fraction of a second of stepping; ``calibrate`` counts the fit's simulations, ``static`` the static
model's samples. ``check_experiment_size`` refuses a run too large for this machine up front.

Modules: ``config`` (``ExperimentConfig``, the file names), ``currents`` (``experiment_currents``),
``dataset`` (``measured_wrenches``, ``orientation_dataset``), ``static`` (the report's entry on the
static predictions), ``comparison`` (``compare``, Table 1), ``figure`` (``plot_fig12``), ``run``
(``run_experiment``) and ``lab`` (the same comparison on lab CSV recordings); their public names are
imported here. The camera model is ``softrnn.magnetics.camera``, the static Cosserat model's
predictions ``softrnn.magnetics.static``.
"""

from .comparison import check_result_shape as check_result_shape
from .comparison import compare as compare
from .comparison import format_table as format_table
from .config import AXES as AXES
from .config import FIGURE_FILE as FIGURE_FILE
from .config import FULL_EPOCHS as FULL_EPOCHS
from .config import FULL_SAMPLES as FULL_SAMPLES
from .config import MAGNETS as MAGNETS
from .config import MODELS_DIR as MODELS_DIR
from .config import ORIENTATION_NOTE as ORIENTATION_NOTE
from .config import QUICK_EPOCHS as QUICK_EPOCHS
from .config import QUICK_SAMPLES as QUICK_SAMPLES
from .config import ROBOT_FILE as ROBOT_FILE
from .config import STAGES as STAGES
from .config import TABLE_FILE as TABLE_FILE
from .config import ExperimentConfig as ExperimentConfig
from .currents import experiment_currents as experiment_currents
from .dataset import measured_wrenches as measured_wrenches
from .dataset import orientation_dataset as orientation_dataset
from .figure import plot_fig12 as plot_fig12
from .run import assumptions as assumptions
from .run import check_experiment_size as check_experiment_size
from .run import run_experiment as run_experiment
