"""Real robots' recordings: sessions read as they come (``recording``), the tendon robot's
displacement-driven physics and its calibration (``tendon_robot``), the model families and the
baselines fitted on training sessions (``families``), the learned families (``nets``) taught by the
physics' synthetic sessions (``synthetic``) and their 90 % intervals (``uncertainty``), the dynamic
physics of a robot's scenario driven by its recorded tensions and its calibration (``dynamic_physics``)
with its families (``dynamic_families``), the benchmark that runs them free over a validation session
(``benchmark``) and a suite of robots benchmarked in turn (``suite``)."""

from .benchmark import BASELINES, FAMILIES, BenchmarkOptions, BenchmarkResult, run_benchmark
from .recording import Layout, Recording, check_sessions, estimate_lag, read_recording, shift_inputs
from .suite import SuiteJob, SuiteResult, run_suite
from .tendon_robot import Calibration, CalibrationOptions, TendonParameters, TendonRobot, calibrate, tip_positions

__all__ = ["BASELINES", "FAMILIES", "BenchmarkOptions", "BenchmarkResult", "Calibration", "CalibrationOptions",
           "Layout", "Recording", "TendonParameters", "TendonRobot", "calibrate", "check_sessions", "estimate_lag",
           "read_recording", "run_benchmark", "shift_inputs", "tip_positions", "SuiteJob", "SuiteResult", "run_suite"]
