"""``softrnn reproduce``: the paper's pipeline, step by step, into one output folder.

The steps, one module each: the data sets of the three simulated cases (section 4, Data-sets I-III)
and of their generalisation variants (``data/*.h5``) with figures and animations (``cases``); the
node model of each case, trained, evaluated one step ahead and free running, generalised, checked
against PyTorch (``node_models``); the whole semicircle with one shared model, Fig. 2C
(``manipulator``); the learned whole-manipulator dynamic model of each case, on its own sweep,
beside its baselines and timed against the simulator (``dynamic``, beyond the paper); the same
model on the two tendon-driven arms, driven by their tensions alone (``tendons``, beyond the
paper); the magnetic experiment simulated, section 5, Table 1, Fig. 12 (``magnetic``); closed-loop control
of the magnetic rod, static-inverse against MPC on a learned model (``control``, beyond the paper);
the static solver's Fig. 13 study (``fig13``); the Fig. 14 hyper-parameter study (``fig14``);
``softrnn bench`` (``benchmark``); then ``report.json`` and ``report.md`` (``report``,
docs/report-format.md). Each finished step leaves its files and a step file (``stepfiles``); a
rerun (after an interruption) skips the steps whose results are present for the same settings and
version.

``reproduce`` calls the step functions (``*_step``) through this module's names, so replacing one
here (a test's monkeypatch) replaces it in the pipeline; what a step uses inside its own module
(``cases.run_case``, ``cases.QUICK_FRACTION``) is replaced there.
"""

import json
import time
from pathlib import Path

from .. import __version__
from ..files import atomic_write_text
from ..learned.threads import (
    REPRODUCE_TORCH_THREADS,
    numerics_in_force,
    passive_waits,
    pin_blas_threads,
    pin_numerics,
    torch_threads,
)
from ..paper import paper_case
from ..progress import ProgressFactory
from ..scenarios.cases import ASSUMPTIONS, PAPER_CASES, build_case
from ..timing import machine_info
from .benchmark import benchmark_step, warm_start
from .cases import GENERALISATION, case_step
from .control import control_step, model_start
from .control import training_jobs as control_jobs
from .dynamic import dynamic_step
from .fig13 import fig13_step
from .fig14 import fig14_step
from .magnetic import magnetic_step
from .manipulator import manipulator_step
from .node_models import model_step, paper_errors
from .report import render_markdown
from .tendons import tendon_step, training_jobs

_MODEL_KEYS = ("one_step", "rollout", "generalisation", "generalisation_rollout", "model", "test_span_s",
               "engine_vs_pytorch")


def _case_reports(report: dict, out: Path, quick: bool, progress_factory: ProgressFactory | None) -> None:
    """Each paper case's block of ``report``: the paper's figures and its two data sets."""
    for name in PAPER_CASES:
        report[name] = {"paper": paper_errors(paper_case(build_case(name).paper_key))}
        for key, case_name in (("simulation", name), ("generalisation_data", GENERALISATION[name])):
            case = build_case(case_name)
            done = case_step(case, out, quick, progress_factory, figures=key == "simulation")
            report[name][key] = done["simulation"]
            if key == "simulation":
                report[name].update(node=case.node_of_interest, length_m=case.setup.rod.length, unit="mm",
                                    figures=done["figures"], dataset=done["dataset"])


def _model_reports(report: dict, out: Path, quick: bool, progress_factory: ProgressFactory | None) -> None:
    """Each paper case's node model into its block of ``report``."""
    for name in PAPER_CASES:
        result = model_step(name, out, quick, progress_factory)
        for key in _MODEL_KEYS:
            report[name][key] = result.get(key)
        report[name]["figures"] = report[name]["figures"] + result["figures"]


def _dynamic_models(out: Path, quick: bool, progress_factory: ProgressFactory | None) -> dict:
    """The paper cases' whole-manipulator models, with the tendon arms' trainings in the same pool of
    workers (their data sets and sweeps made first, ``tendons.training_jobs``; ``tendon_step`` then
    measures them) and, last, the control step's model (``control.training_jobs``)."""
    also = training_jobs(out, quick, progress_factory) + control_jobs(out, quick)
    return dynamic_step(out, quick, progress_factory, also=also)


def _control(out: Path, quick: bool, progress_factory: ProgressFactory | None, identifying) -> dict:
    """The control step, once its model's background process (``control.model_start``, or None) ended."""
    if identifying is not None:
        identifying.join()
    return control_step(out, quick, progress_factory)


def reproduce(out_dir, *, quick: bool = False, progress_factory: ProgressFactory | None = None) -> dict:
    """Run every step into ``out_dir`` and return the report dictionary.

    ``progress_factory(description)`` returns the ``softrnn.progress.Progress`` of each step (e.g. a
    progress bar); None: silent.
    """
    out = Path(out_dir)
    (out / "cases").mkdir(parents=True, exist_ok=True)
    numerics = pin_numerics()       # before PyTorch's first operation: the same figures on every machine
    waits = passive_waits()         # before PyTorch's import: no thread spins against another process
    blas = pin_blas_threads()       # NumPy's and SciPy's sums in one order on every machine
    import torch  # noqa: F401  # optional extra: learn (PyTorch), loaded so that its threads can be set
    report = {"softrnn_version": __version__, "quick": quick,
              "machine": {**machine_info(), "numerics": numerics, "numerics_in_force": numerics_in_force(),
                          "torch_threads": REPRODUCE_TORCH_THREADS,
                          "blas_threads": blas, "waits": waits},
              "assumptions": ASSUMPTIONS}
    with torch_threads(REPRODUCE_TORCH_THREADS):
        _steps(report, out, quick, progress_factory)
    atomic_write_text(out / "report.json", json.dumps(report, indent=2))
    atomic_write_text(out / "report.md", render_markdown(report))
    return report


def _steps(report: dict, out: Path, quick: bool, progress_factory: ProgressFactory | None) -> None:
    """Every step in order into ``report``, and each step's wall seconds into its ``step_seconds``."""
    seconds = {}

    def timed(name, step, *args):
        t0 = time.perf_counter()
        result = step(*args)
        seconds[name] = round(time.perf_counter() - t0, 1)
        return result

    warming = warm_start(out, quick)    # the benchmark's compiles, on the core the first steps leave idle
    timed("cases", _case_reports, report, out, quick, progress_factory)
    identifying = model_start(out, quick)   # the control step's model, likewise (after the cases: their kernel cached)
    timed("node_models", _model_reports, report, out, quick, progress_factory)
    report["manipulator"] = timed("manipulator", manipulator_step, out, quick, progress_factory)
    report["dynamic_model"] = timed("dynamic_model", _dynamic_models, out, quick, progress_factory)
    report["tendons"] = timed("tendons", tendon_step, out, quick, progress_factory)
    warming_model = warm_start(out, quick, "model")   # the model benchmark's, on the core the magnetic step leaves
    report["magnetic"] = timed("magnetic", magnetic_step, out, quick, progress_factory)
    report["control"] = timed("control", _control, out, quick, progress_factory, identifying)
    report["fig13"] = timed("fig13", fig13_step, out, quick)
    report["fig14"] = timed("fig14", fig14_step, out, quick, progress_factory)
    for process in (warming, warming_model):  # compiled long before: the benchmark times alone
        if process is not None:
            process.join()
    report["benchmark"] = timed("benchmark", benchmark_step, out, quick, progress_factory)
    report["step_seconds"] = seconds
