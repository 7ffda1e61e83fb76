"""A reproduce report against a committed reference: which accuracy figures moved.

CI runs the quick reproduce cold and compares its ``report.json`` with the committed quick reference
(``docs/results/reference-quick``); a figure that moved fails the run, so the published results
cannot go stale. The comparison is exact: every number, boolean and word of the report is a figure,
except what measures the machine rather than the method (timings, speeds and every figure derived
from one, the machine's description, file paths and the softrnn version). A change that moves a figure
on purpose regenerates both references in the same commit (``make references``, ``save_reference``)
and says why (CONTRIBUTING.md, "Reference results").

Run as ``softrnn reproduce --compare REF``: the run (or its resumption, instant when it is finished),
then the comparison.
"""

from __future__ import annotations

import datetime
import json
import os
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

from ..errors import bad, one_line
from ..files import atomic_write_text

TIMING = re.compile(
    r"(^|[._])(us|ms)([._]|$)|hz|per_s(econd)?($|_)|seconds|minutes|wall|speed|realtime|real_time|cpu_fraction"
    r"|load_average|overhead|elapsed|compile|cached_(s|start|reps)|import_s|timing|bandwidth|^date$"
    r"|^(engine|pytorch|rollout|baselines|simulation|static|training|total|total_time|cold)_s$")
"""A key (any level of the path) that holds a timing or a figure derived from one: wall and CPU times,
speeds and rates, compile and import times, the Fig. 14 inference bandwidths and the best region by
them, the speed goals; ``machine`` and ``softrnn_version`` are left out by name (``MACHINE_KEYS``)."""

TIMING_ENTRIES = re.compile(r"^benchmark(/|\[|$)|^(dynamic_model|tendons)/[^/]+/step_s$")
"""Timings by their place in the report: the whole ``benchmark`` (``softrnn bench``: speeds, and the
settings and choices made by speed, e.g. the fastest thread count and its goal flags), and a
whole-manipulator step's wall seconds (``step_s`` is the integration step in a simulation's summary)."""

MACHINE_KEYS = frozenset({"machine", "softrnn_version", "threads", "torch_threads", "usable_cores", "cores"})
"""Keys that describe the machine or the software version, not the method."""

_PATH = re.compile(r"/|\\|\.(h5|json|png|gif|csv|md|onnx|pt|safetensors)$")


@dataclass(frozen=True)
class Moved:
    """One figure that differs between a run and its reference.

    Attributes
    ----------
    key : str
        The figure's place in the report, e.g. ``ellipse/one_step/max_abs[0]``.
    reference : object
        Its value in the reference (``MISSING`` when the reference lacks it).
    run : object
        Its value in the run (``MISSING`` when the run lacks it).
    """

    key: str
    reference: object
    run: object

    def line(self) -> str:
        """``key: reference -> run`` with the relative change of a number."""
        change = ""
        if _number(self.reference) and _number(self.run) and self.reference:
            change = f"  ({(self.run - self.reference) / abs(self.reference):+.2e} relative)"
        return f"{self.key}: {self.reference!r} -> {self.run!r}{change}"


MISSING = "<missing>"


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _walk(x, parts: tuple):
    """(path parts, leaf value) of every leaf of a JSON tree; list indices as ints."""
    if isinstance(x, dict):
        for k, v in x.items():
            yield from _walk(v, parts + (str(k),))
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from _walk(v, parts + (i,))
    else:
        yield parts, x


def _key(parts: tuple) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f"/{p}" if out else p)
    return out


def is_timing(parts: tuple) -> bool:
    """Whether the report entry at ``parts`` (keys and list indices) measures the machine: a timing,
    a speed or a figure derived from one, the machine's description, or the version."""
    names = [p for p in parts if isinstance(p, str)]
    return any(n in MACHINE_KEYS or TIMING.search(n) for n in names)


def figures(report: dict) -> dict[str, object]:
    """The report's accuracy figures, ``{key: value}``: every leaf except timings (``is_timing``) and
    file paths (a string with a slash or a file suffix)."""
    out = {}
    for parts, v in _walk(report, ()):
        key = _key(parts)
        if not (is_timing(parts) or TIMING_ENTRIES.match(key) or (isinstance(v, str) and _PATH.search(v))):
            out[key] = v
    return out


def compare(run: dict, reference: dict) -> list[Moved]:
    """Every accuracy figure of ``run`` that differs from ``reference`` (exactly; NaN equals NaN), and
    every one that only one of them has, in key order."""
    a, b = figures(reference), figures(run)
    moved = []
    for key in sorted(set(a) | set(b)):
        ra, rb = a.get(key, MISSING), b.get(key, MISSING)
        if ra != rb and not (isinstance(ra, float) and isinstance(rb, float) and ra != ra and rb != rb):
            moved.append(Moved(key, ra, rb))
    return moved


def load_report(path: str | os.PathLike, argument: str = "report") -> dict:
    """``report.json`` of a reproduce folder, or the file itself; a missing or unreadable one raises
    ``bad(argument, ...)``."""
    p = Path(path)
    file = p / "report.json" if p.is_dir() else p
    try:
        report = json.loads(file.read_text())
    except (OSError, ValueError) as exc:
        raise bad(argument, str(path), f"a reproduce folder with report.json, or a report.json file "
                                       f"({one_line(exc)})") from None
    if not isinstance(report, dict) or "quick" not in report:
        raise bad(argument, str(path), "the report.json of a softrnn reproduce run")
    return report


def summary(moved: list[Moved], compared: int, limit: int = 30) -> str:
    """The short diff: how many figures moved, then the first ``limit`` of them, one a line."""
    if not moved:
        return f"all {compared} accuracy figures equal the reference (timings not compared)"
    lines = [f"{len(moved)} of {compared} accuracy figures moved from the reference:"]
    lines += [f"  {m.line()}" for m in moved[:limit]]
    if len(moved) > limit:
        lines.append(f"  ... and {len(moved) - limit} more")
    return "\n".join(lines)


def check(run_path, reference_path) -> tuple[bool, str]:
    """Compare two reports (folders or files): (True when no figure moved, the summary). A quick run
    against a full reference (or the reverse) is refused: ``quick`` must match."""
    run, ref = load_report(run_path), load_report(reference_path)
    if run.get("quick") != ref.get("quick"):
        kinds = {True: "quick", False: "full"}
        return False, (f"{run_path} is a {kinds.get(run.get('quick'))} run but {reference_path} a "
                       f"{kinds.get(ref.get('quick'))} one: compare like with like")
    moved = compare(run, ref)
    text = summary(moved, len(set(figures(run)) | set(figures(ref))))
    differences = code_path_differences(run, ref)
    if moved and differences:
        text += "\nthe run's numeric code paths differ from the reference's: " + "; ".join(differences)
    return not moved, text


CODE_PATHS = ("numpy", "numba", "torch", "python", "numerics", "numerics_in_force", "torch_threads", "blas_threads")
"""The entries of a report's ``machine`` that decide its figures' last digits (libraries' versions,
the pinned and the actual code paths, thread counts), named when figures moved (``check``)."""


def code_path_differences(run: dict, reference: dict) -> list[str]:
    """``entry: reference -> run`` for each entry of ``CODE_PATHS`` (and each of its keys) in which
    the two reports' ``machine`` differ; the processor's name too when anything else does."""
    a, b = reference.get("machine") or {}, run.get("machine") or {}
    out = []
    for name in CODE_PATHS:
        x, y = a.get(name, MISSING), b.get(name, MISSING)
        if isinstance(x, dict) and isinstance(y, dict):
            out += [f"{name}.{k}: {x.get(k, MISSING)} -> {y.get(k, MISSING)}"
                    for k in sorted(set(x) | set(y)) if x.get(k, MISSING) != y.get(k, MISSING)]
        elif x != y:
            out.append(f"{name}: {x} -> {y}")
    if out and a.get("cpu") != b.get("cpu"):
        out.append(f"cpu: {a.get('cpu', MISSING)} -> {b.get('cpu', MISSING)}")
    return out


def _commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=True)
        return out.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def save_reference(run_dir, ref_dir, *, notes: str = "") -> None:
    """Make ``ref_dir`` the reference of the finished reproduce in ``run_dir``: its ``report.json`` and
    ``report.md``, the figures the reference already shows (``figures/*.png`` present in ``ref_dir``),
    and ``run.json`` (commit, date, command, machine, the steps' summed wall time, ``notes``)."""
    run, ref = Path(run_dir), Path(ref_dir)
    report = load_report(run)
    ref.mkdir(parents=True, exist_ok=True)
    for name in ("report.json", "report.md"):
        atomic_write_text(ref / name, (run / name).read_text())
    if (ref / "figures").is_dir():
        for png in (ref / "figures").glob("*.png"):
            png.write_bytes((run / "figures" / png.name).read_bytes())
    m = report.get("machine", {})
    quick = " --quick" if report.get("quick") else ""
    info = {"commit": _commit(), "date": report.get("date") or _today(),
            "command": f"softrnn reproduce{quick} -o {run.as_posix()}",
            "machine": f"{m.get('cpu')}, {m.get('cores')} cores ({m.get('system')}, Python {m.get('python')}, "
                       f"PyTorch {m.get('torch')})",
            "wall_time_s": round(sum(report.get("step_seconds", {}).values())), "notes": notes}
    atomic_write_text(ref / "run.json", json.dumps(info, indent=2) + "\n")


def _today() -> str:
    return datetime.date.today().isoformat()

