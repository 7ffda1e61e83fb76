"""The calibration core as ``softrnn calibrate`` and its importers know it: the names of
``softrnn.fitting`` (bounded least squares over a simulator's parameters, with parallel finite
differences, resuming and a report; the method in ``softrnn.fitting.least_squares``)."""

from ..fitting import CORRELATION_LIMIT as CORRELATION_LIMIT
from ..fitting import PENALTY as PENALTY
from ..fitting import FitOptions as FitOptions
from ..fitting import FitResult as FitResult
from ..fitting import Parameter as Parameter
from ..fitting import fit as fit
from ..fitting import run_trial as run_trial
from ..fitting import stop_reason as stop_reason
