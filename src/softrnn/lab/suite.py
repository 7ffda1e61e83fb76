"""The real-robot benchmark over a suite of robots (``softrnn lab benchmark --suite``,
docs/guide/real-robots.md): every robot checked before any runs, each benchmarked in turn with its
report kept in a folder (a finished robot is kept and skipped when the suite is run again with
``resume``), and one table of every robot's models and baselines (``SuiteResult``: JSON and Markdown).

The suite file is read by ``softrnn.scenarios.suite``; the command line turns its entries into
``SuiteJob`` entries.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path

from ..errors import SoftrnnInputError
from ..files import atomic_write_text
from .benchmark import BenchmarkOptions, Choice, Prepared, TipScore, prepare, run_prepared
from .recording import Layout, read_recording

REPORT_FORMAT = 1
"""The format of the ``suite`` entry a robot's report carries (what resuming compares)."""


@dataclass(frozen=True)
class SuiteJob:
    """One robot of a suite, ready to run.

    Attributes
    ----------
    name : str
        the robot's name (its report is ``NAME.json`` in the suite's folder)
    entry : str
        where errors point: the suite file and the robot's entry, e.g. ``suite.toml: robots.arm``
    train, validation : tuple of str, str
        the sessions' paths
    layout : Layout
        the sessions' columns
    options : BenchmarkOptions
        what the benchmark runs
    """

    name: str
    entry: str
    train: tuple
    validation: str
    layout: Layout
    options: BenchmarkOptions

    def fingerprint(self) -> str:
        """sha256 of the options, the layout and every session file's bytes: a kept report is reused
        only for the same robot, sessions and options."""
        h = hashlib.sha256(repr((REPORT_FORMAT, self.options, self.layout)).encode())
        for path in (*self.train, self.validation):
            h.update(Path(path).read_bytes())
        return h.hexdigest()


@dataclass(frozen=True)
class SuiteRow:
    """One robot's line of the suite's table (from its benchmark report).

    Attributes
    ----------
    name, report : str, str
        the robot and its report file (JSON)
    length_m : float
        the robot's length [m]
    training_rows, validation_rows : int, int
        the rows of the training sessions (all) and of the validation session, after the lag
    models, baselines : dict of str to TipScore
        each model family's and baseline's scores over the validation session
    chosen : Choice or None
        the family the training hold-out chose
    best_model, best_baseline : str or None
        the best of each on the validation session
    seconds : float
        the robot's benchmark wall time [s]
    resumed : bool
        kept from an earlier run
    agreement : dict or None
        the physics' tip RMSE over the validation session [mm], calibrated on the training sessions,
        on every session and on the validation session alone (the report's ``session_agreement``; None
        where the physics did not run)
    """

    name: str
    report: str
    length_m: float
    training_rows: int
    validation_rows: int
    models: dict
    baselines: dict
    chosen: Choice | None
    best_model: str | None
    best_baseline: str | None
    seconds: float
    resumed: bool = False
    agreement: dict | None = None

    @classmethod
    def from_report(cls, name: str, path, report: dict, resumed: bool = False) -> SuiteRow:
        """The row of a benchmark report (``BenchmarkResult.to_dict()``) written to ``path``."""
        robot = report["robot"]
        return cls(name=name, report=str(path), length_m=robot["length_m"],
                   training_rows=sum(s["rows"] for s in robot["training_sessions"]),
                   validation_rows=robot["validation_session"]["rows"],
                   models={k: TipScore(**v) for k, v in report["models"].items()},
                   baselines={k: TipScore(**v) for k, v in report["baselines"].items()},
                   chosen=Choice(**report["chosen_on_training"]) if report["chosen_on_training"] else None,
                   best_model=report["best_model"], best_baseline=report["best_baseline"],
                   seconds=report["seconds"], resumed=resumed, agreement=_agreement(report))

    @property
    def chosen_to_best_baseline(self) -> float | None:
        """The chosen family's validation tip RMSE over the best baseline's (None: no family)."""
        if self.chosen is None or self.best_baseline is None:
            return None
        chosen, best = self.models[self.chosen.family].tip_rmse_mm, self.baselines[self.best_baseline].tip_rmse_mm
        return None if chosen is None or best is None else chosen / best      # None: a run that diverged

    def to_dict(self) -> dict:
        """The robot's entry of the suite's JSON."""
        ratio = self.chosen_to_best_baseline
        return {"report": self.report, "length_m": self.length_m, "training_rows": self.training_rows,
                "validation_rows": self.validation_rows,
                "models": {k: v.to_dict() for k, v in self.models.items()},
                "baselines": {k: v.to_dict() for k, v in self.baselines.items()},
                "best_model": self.best_model, "best_baseline": self.best_baseline,
                "chosen_on_training": {} if self.chosen is None else {
                    "family": self.chosen.family, "validation_tip_rmse_mm": self.chosen.validation_tip_rmse_mm},
                "ratio_chosen_to_best_baseline": None if ratio is None else round(ratio, 4),
                "session_agreement": self.agreement, "seconds": self.seconds, "resumed": self.resumed}


def _agreement(report: dict) -> dict | None:
    """{calibrated on: the physics' validation tip RMSE [mm]} of a report's ``session_agreement``."""
    found = report.get("session_agreement")
    return None if not found else {k: found[k]["validation_tip_rmse_mm"]
                                   for k in ("training_only", "training_and_validation", "validation_only")}


_COLUMNS = (("tip RMSE [mm]", "tip_rmse_mm"), ("mean [mm]", "tip_mean_mm"),
            ("RMSE [% of L]", "tip_rmse_pct_of_length"), ("mean [% of L]", "tip_mean_pct_of_length"),
            ("aligned RMSE [mm]", "tip_rmse_aligned_mm"), ("aligned mean [mm]", "tip_mean_aligned_mm"),
            ("aligned mean [% of L]", "tip_mean_aligned_pct_of_length"),
            ("per pattern: aligned mean [% of L]", "tip_mean_aligned_per_pattern_pct_of_length"),
            ("coverage 90 %", "coverage_90"))
"""The Markdown table's score columns: (title, ``TipScore`` attribute)."""


def _cell(value) -> str:
    return "–" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.2f}"


@dataclass(frozen=True)
class SuiteResult:
    """What ``run_suite`` found: one ``SuiteRow`` per robot, in the suite's order.

    Attributes
    ----------
    suite, title : str, str
        the suite file and its title
    rows : tuple of SuiteRow
        the robots
    """

    suite: str
    title: str
    rows: tuple

    def to_dict(self) -> dict:
        """The suite's JSON (docs/guide/real-robots.md)."""
        return {"suite": self.suite, "title": self.title, "robots": {r.name: r.to_dict() for r in self.rows}}

    def markdown(self) -> str:
        """The suite's tables in Markdown: each robot's chosen family against its best baseline, then
        every model and baseline of every robot."""
        lines = [f"# {self.title}", "",
                 "| robot | training rows | validation rows | chosen on training | its tip RMSE [mm] "
                 "| best baseline | chosen / best baseline | best model | physics fitted on every session [mm] "
                 "| time [s] |", "|---" * 10 + "|"]
        for r in self.rows:
            chosen = r.chosen.family if r.chosen else "–"
            rmse = r.chosen.validation_tip_rmse_mm if r.chosen else None
            lines.append(f"| {r.name} | {r.training_rows} | {r.validation_rows} | {chosen} | {_cell(rmse)} | "
                         f"{r.best_baseline or '–'} | {_cell(r.chosen_to_best_baseline)} | {r.best_model or '–'} | "
                         f"{_cell(r.agreement and r.agreement['training_and_validation'])} | {r.seconds:.0f} |")
        lines += ["", "| robot | model | " + " | ".join(t for t, _ in _COLUMNS) + " |",
                  "|---|---|" + "---|" * len(_COLUMNS)]
        for r in self.rows:
            for kind, table in (("", r.models), (" (baseline)", r.baselines)):
                for name, score in table.items():
                    cells = [_cell(getattr(score, a)) if a != "coverage_90" or score.coverage_90 is None
                             else f"{score.coverage_90 * 100:.1f} %" for _, a in _COLUMNS]
                    lines.append(f"| {r.name} | `{name}`{kind} | " + " | ".join(cells) + " |")
        lines += ["", "Free run over each robot's validation session from its start on the commands alone; "
                      "physics fitted on every session: its tip RMSE over the validation session, calibrated on "
                      "the training and validation sessions together (how far the sessions agree, a diagnostic); "
                      "aligned: after removing the constant offset between model and measurement over the "
                      "session; per pattern: after removing it over each pattern (each run of rows with one label; "
                      "– where the session has no labels); coverage: the share of rows inside the model's stated 90 % "
                      "ball."]
        return "\n".join(lines) + "\n"


def check_suite(jobs) -> list[Prepared]:
    """Read and check every robot's sessions before any runs (``benchmark.prepare``): the first
    problem is a one-line ``SoftrnnInputError`` that starts with the robot's ``entry``."""
    prepared = []
    for job in jobs:
        try:
            train = [read_recording(p, job.layout) for p in job.train]
            prepared.append(prepare(train, read_recording(job.validation, job.layout), job.options))
        except SoftrnnInputError as err:
            raise SoftrnnInputError(f"{job.entry}: {err}") from None
    return prepared


def _kept(path: Path, fingerprint: str) -> dict | None:
    """The report at ``path`` when it was written for the same ``fingerprint``, else None."""
    try:
        report = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    ok = isinstance(report, dict) and report.get("suite", {}).get("fingerprint") == fingerprint
    return report if ok else None


def run_suite(jobs, folder, *, suite: str = "", title: str = "", resume: bool = False,
              progress=None) -> SuiteResult:
    """Benchmark each of ``jobs`` (``SuiteJob``) in turn, every one checked first (``check_suite``);
    write each robot's report to ``folder/NAME.json`` as it finishes. ``resume``: a robot whose report
    is there for the same sessions and options is kept, not run again. ``progress(done, total,
    {"stage": "NAME: stage"})`` after each stage of every robot run."""
    prepared = check_suite(jobs)
    folder = Path(folder)
    fingerprints = [job.fingerprint() for job in jobs]
    kept = [_kept(folder / f"{job.name}.json", f) if resume else None for job, f in zip(jobs, fingerprints)]
    total = sum(p.stages for p, k in zip(prepared, kept) if k is None)
    done, rows = 0, []
    for job, ready, fingerprint, report in zip(jobs, prepared, fingerprints, kept):
        path = folder / f"{job.name}.json"
        if report is not None:
            rows.append(SuiteRow.from_report(job.name, path, report, resumed=True))
            continue

        def step(k, _total, info, base=done, name=job.name):
            if progress is not None:
                progress(base + k, total, {"stage": f"{name}: {info['stage']}"})

        report = run_prepared(ready, job.options, progress=step).to_dict()
        report["suite"] = {"name": job.name, "entry": job.entry, "fingerprint": fingerprint}
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps(report, indent=2) + "\n")
        done += ready.stages
        rows.append(SuiteRow.from_report(job.name, path, report))
    return SuiteResult(suite=suite, title=title, rows=tuple(rows))
