"""The one calibration core: a bounded least-squares fit of parameters to recordings
(``scipy.optimize.least_squares``, called in ``least_squares.solve`` alone). ``fit`` fits a
simulator's named ``Parameter`` values, with finite differences run in batches (in this process or
on Dask), failed trials penalised, standard errors and identifiability in its report
(``FitResult``) and every trial kept to resume; ``multistart`` fits a cheap residual from several
starts and refines the best, or resumes from an earlier fit. Used by ``softrnn.calibration`` (a
scenario fitted to a dataset), the magnetic experiment's calibration
(``softrnn.experiments.magnetic.calibration``) and the tendon robot's (``softrnn.lab.tendon_robot``)."""

from .least_squares import CORRELATION_LIMIT as CORRELATION_LIMIT
from .least_squares import PENALTY as PENALTY
from .least_squares import fit as fit
from .least_squares import solve as solve
from .parameters import FitOptions as FitOptions
from .parameters import FitResult as FitResult
from .parameters import Parameter as Parameter
from .parameters import stop_reason as stop_reason
from .starts import MultiStart as MultiStart
from .starts import StartOptions as StartOptions
from .starts import multistart as multistart
from .trials import InProcess as InProcess
from .trials import run_trial as run_trial
