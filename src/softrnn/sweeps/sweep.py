"""Sweeps: many randomised variants of a scenario, simulated in parallel on Dask.

Each variant i is ``scenario.variant(i)`` (deterministic from the scenario's seed and i) and is
written to ``DIR/traj-{i:05d}.h5`` atomically, so a sweep that is interrupted and run again
computes only the missing files, and its result equals an uninterrupted run. ``DIR/sweep.json``
records what the folder holds; a rerun with another scenario or seed is refused.

Dask: a ``distributed.LocalCluster`` of ``n_workers`` single-threaded processes by default, or an
existing cluster given by its scheduler address (``tcp://HOST:PORT``); the workers need softrnn
installed (same version).
"""

import errno
import hashlib
import json
import time
from contextlib import closing
from dataclasses import dataclass, field, replace
from pathlib import Path

from .. import __version__
from ..errors import FileFault, SoftrnnInputError, bad, positive
from ..files import KEPT, atomic_write_text
from ..io.reader import read_dataset
from ..io.schema import DatasetError, check_trajectory_room
from ..io.writer import DatasetWriter
from ..progress import Progress
from ..resume import REFUSE, Settings, check
from ..rod import Simulator
from ..rod.hub import run_channels, run_sink
from ..scenarios.magnetic import magnetic_summary
from ..scenarios.scenario import parse_scenario
from .dask import completed, require

MANIFEST = "sweep.json"
MAX_COUNT = 100_000
"""Most variants of one sweep: its files ``traj-00000.h5`` .. ``traj-99999.h5`` (five digits) keep
their order by name, which the readers of a sweep folder use (``--heldout N``: the last N)."""
SETTINGS = ("dt", "n_samples", "scenario_sha256", "seed")
"""The keys of ``sweep.json`` a resumed sweep must match (the others describe it)."""


def trajectory_path(out_dir, index: int) -> Path:
    """File of variant ``index`` in a sweep folder."""
    return Path(out_dir) / f"traj-{index:05d}.h5"


@dataclass
class SweepResult:
    """What a sweep call did: indices computed now, indices found complete, all files, wall time."""

    computed: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    files: list = field(default_factory=list)
    wall_time: float = 0.0


def _fingerprint(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def _check_manifest(out_dir: Path, scenario, n_samples, dt=None) -> None:
    """Write the manifest, or refuse a folder that holds another scenario's sweep (or the same
    scenario with another length or saved interval; ``dt`` None: the scenario's own)."""
    want = {"scenario": scenario.name, "source": scenario.source, "scenario_sha256": _fingerprint(scenario.text),
            "seed": scenario.seed, "n_samples": n_samples, "dt": dt, "softrnn_version": __version__}
    path = out_dir / MANIFEST
    if path.exists():
        try:
            have = json.loads(path.read_text())
        except (OSError, ValueError) as err:
            raise bad("-o", str(out_dir), f"a sweep folder; its {MANIFEST} is unreadable ({err}); "
                                           f"remove it or use another folder") from err
        check(have, Settings.of(want, keys=SETTINGS), otherwise=REFUSE, refuse=lambda diff: bad(
            "-o", str(out_dir), f"a folder for this sweep, but it holds a sweep of another scenario/seed/length/dt "
                                f"({diff.key}: {diff.old!r} != {diff.new!r}); use another folder"))
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(want, indent=2))


def _is_complete(path: Path) -> bool:
    """A finished trajectory file: readable, of this format (writes are atomic, so present = whole)."""
    if not path.exists():
        return False
    try:
        read_dataset(path, nodes=[], stop=1)
        return True
    except (DatasetError, OSError, ValueError):
        return False


def run_variant(text: str, source: str, index: int, path: str, n_samples: int | None = None,
                dt: float | None = None) -> dict:
    """Simulate variant ``index`` of the scenario given by its TOML ``text`` and write it to
    ``path`` (atomically), ``n_samples`` samples ``dt`` s apart (None: the scenario's), with its
    tendons' tensions as the actuation channels ``tendon_<name>`` [N] and a hub's (``rod.hub``). Runs on a Dask worker;
    returns a small summary."""
    if not (Path(path).parent / MANIFEST).is_file():    # the folder went: the writers must not make it again
        raise FileFault(f"cannot write {path}: its sweep folder is gone")
    scenario = parse_scenario(text, source).variant(index)
    config = run_config(scenario.config, n_samples, dt)
    attrs = {"variant_index": index, "sampled": json.dumps(scenario.sampled), "scenario_name": scenario.name}
    if scenario.magnetic is not None:  # the manipulator: a rod with the magnets' load; coil currents as actuation
        summary = magnetic_summary(name=scenario.name, title=scenario.title, magnetic=scenario.magnetic,
                                   config=config, node=scenario.nodes_of_interest[0], out_path=path,
                                   scenario_text=scenario.text, seed=scenario.seed, attrs=attrs,
                                   record=scenario.record)
        return {"index": index, "wall_time": summary["total_time_s"], "substeps": summary["substeps"]}
    sim = Simulator(scenario.setup)
    nodes = list(range(scenario.setup.rod.n_nodes)) if config.save_nodes is None else list(config.save_nodes)
    start = time.perf_counter()
    units = run_channels(scenario.setup)  # tendon tensions tendon_<name> [N], then the hub's channels
    with DatasetWriter(path, nodes=nodes, n_samples=config.n_samples, dt=config.dt, rod=scenario.setup.rod,
                       scenario_text=scenario.text, seed=scenario.seed, attrs=attrs, actuation_units=units,
                       contact=scenario.setup.contact, record=scenario.record) as writer:
        stats = sim.run(config, sink=run_sink(writer.append, scenario.setup, nodes))
    return {"index": index, "wall_time": time.perf_counter() - start, "substeps": stats.substeps}


def run_config(config, n_samples: int | None = None, dt: float | None = None):
    """The scenario's ``RunConfig`` with ``n_samples`` and/or the saved interval ``dt`` [s] replaced
    (None: kept); the solver's substeps are chosen for the new interval when the scenario's are
    automatic."""
    changes = {k: v for k, v in (("n_samples", n_samples), ("dt", dt)) if v is not None}
    return replace(config, **changes) if changes else config


def _remove_stale_temporaries(out_dir: Path) -> None:
    for p in out_dir.glob("traj-*.h5.tmp*"):
        p.unlink(missing_ok=True)
    for p in out_dir.glob(".traj-*"):
        p.unlink(missing_ok=True)


def check_sweep(scenario, count, *, n_workers=2, n_samples=None, dt=None) -> float | None:
    """Refuse, before any file, worker or step, a sweep that cannot run or is too large for this
    machine (``rod.simulation.check_run_size``, as ``softrnn simulate`` does): one line naming the
    option (``SoftrnnInputError``).

    Parameters
    ----------
    scenario : Scenario
        The scenario whose variants are simulated (it needs a [randomize] table).
    count, n_workers : int
        Variants 0..count-1 (``--count``, at most ``MAX_COUNT``); local worker processes (``--workers``).
    n_samples, dt : int or None, float or None
        Samples per trajectory (``--samples``) and the saved interval [s] (``--dt``); None: the scenario's.

    Returns
    -------
    float or None
        ``dt`` as a float.
    """
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise bad("--count", count, "an integer >= 1")
    if count > MAX_COUNT:
        raise bad("--count", count, f"at most {MAX_COUNT} variants: a larger sweep is too large for one folder "
                                    f"(its files traj-00000 .. traj-{MAX_COUNT - 1:05d} keep their order by name, "
                                    "which the readers of a sweep folder use); split it into scenarios with other "
                                    "seeds")
    if isinstance(n_workers, bool) or not isinstance(n_workers, int) or n_workers < 1:
        raise bad("--workers", n_workers, "an integer >= 1")
    if n_samples is not None and (isinstance(n_samples, bool) or not isinstance(n_samples, int) or n_samples < 1):
        raise bad("--samples", n_samples, "an integer >= 1")
    if dt is not None:
        dt = positive("--dt", dt, "s")
    if not scenario.randomized:
        raise bad("scenario", scenario.name, "a scenario with a [randomize] table (nothing to vary in a sweep)")
    _check_run_size(scenario, n_samples, dt)
    return dt


def _too_large(sim, scenario, n_samples, dt) -> str | None:
    """``check_run_size``'s refusal of one variant's run with these settings, or None where it fits
    (other errors of the run's settings are raised)."""
    config = run_config(scenario.config, n_samples, dt)
    try:
        if scenario.magnetic is None:
            sim.check_size(config, streamed=True)
        else:           # the manipulator holds every sample (check_manipulator_run)
            scenario.magnetic.check_size(config)
    except SoftrnnInputError as err:
        if not str(err).startswith("the run "):
            raise
        return str(err)
    return None


def _check_run_size(scenario, n_samples, dt) -> None:
    """Refuse one variant's run too large for this machine, naming what makes it so: ``--samples``
    or ``--dt`` (the one too large with the scenario's other setting), both, or the scenario."""
    sim = Simulator(scenario.setup)
    why = _too_large(sim, scenario, n_samples, dt)
    if why is None:
        return
    for flag, value, alone in (("--samples", n_samples, (n_samples, None)), ("--dt", dt, (None, dt))):
        if value is not None and _too_large(sim, scenario, *alone) is not None:
            raise bad(flag, value, f"a shorter run per variant: {why}")
    if n_samples is not None and dt is not None:
        raise SoftrnnInputError(f"--samples={n_samples!r} with --dt={dt!r} is invalid: a shorter run per variant: "
                                f"{why}")
    raise bad("scenario", scenario.name, f"a scenario whose run fits this machine (or a smaller --samples or "
                                         f"--dt): {why}")


def run_sweep(scenario, count: int, out_dir, *, scheduler: str | None = None, n_workers: int = 2,
              n_samples: int | None = None, dt: float | None = None,
              progress: Progress | None = None) -> SweepResult:
    """Simulate variants 0..count-1 of ``scenario`` into ``out_dir`` on Dask; skips finished files.

    ``scheduler``: address of an existing Dask scheduler, or None for a LocalCluster of
    ``n_workers`` processes. ``n_samples`` sets every trajectory's length (default: the scenario's)
    and ``dt`` its saved interval [s] (default: the scenario's; the solver step stays the stable
    one, so a coarser ``dt`` saves fewer samples, not a coarser simulation). Both are recorded in
    ``sweep.json``: resuming with others is refused. ``progress(done, count)`` counts finished
    trajectories, found or computed.
    """
    dt = check_sweep(scenario, count, n_workers=n_workers, n_samples=n_samples, dt=dt)
    require()
    out = Path(out_dir)
    missing = sum(not trajectory_path(out, i).exists() for i in range(count))
    if missing:     # before the folder is made
        _check_room(scenario, out, missing, n_samples, dt)
    _check_manifest(out, scenario, n_samples, dt)
    _remove_stale_temporaries(out)
    result = SweepResult(files=[trajectory_path(out, i) for i in range(count)])
    todo = []
    for i in range(count):
        (result.skipped if _is_complete(trajectory_path(out, i)) else todo).append(i)
    done = len(result.skipped)
    if progress is not None:
        progress(done, count)
    start = time.perf_counter()
    try:
        for index in _execute(scenario, todo, out, scheduler, n_workers, n_samples, dt) if todo else ():
            if not (out / MANIFEST).is_file():
                raise _Gone
            result.computed.append(index)
            done += 1
            if progress is not None:
                progress(done, count)
    except (OSError, _Gone) as err:   # the workers are stopped here
        if not (out / MANIFEST).is_file():
            raise _gone(out, todo, done, count) from None
        if not isinstance(err, (FileFault, _Gone)):
            raise
        raise FileFault(str(err).replace(KEPT, f"{KEPT}, and the {done} finished variants are kept in {out}: run the "
                                               f"same command again to continue")) from None
    result.wall_time = time.perf_counter() - start
    result.computed.sort()
    return result


class _Gone(Exception):
    """The sweep folder's manifest is gone: the folder was removed or moved (``_gone``)."""


def _gone(out: Path, todo: list, done: int, count: int) -> FileFault:
    """The one-line fault of a sweep folder removed or moved while the sweep ran (after ``done`` of
    ``count`` variants): a folder of that name a worker made again meanwhile (without the manifest)
    is removed with the files of ``todo`` it wrote there."""
    if out.is_dir() and not (out / MANIFEST).exists():
        _remove_stale_temporaries(out)
        for i in todo:
            trajectory_path(out, i).unlink(missing_ok=True)
        if not any(out.iterdir()):
            out.rmdir()
    fault = FileFault(f"the sweep folder {out} was removed or moved while the sweep ran ({done} of {count} variants "
                      f"finished); put it back where it was (a moved folder keeps its finished variants) or choose "
                      f"another output, and run the same command again: finished variants are not computed again")
    fault.errno = errno.ENOENT
    return fault


def _check_room(scenario, out: Path, count: int, n_samples, dt) -> None:
    """Refuse up front ``count`` more variants' files that would not fit the disk of ``out``
    (``io.schema.check_trajectory_room``; the manipulator's files are not estimated)."""
    if scenario.magnetic is not None:
        return
    config, setup = run_config(scenario.config, n_samples, dt), scenario.setup
    nodes = setup.rod.n_nodes if config.save_nodes is None else len(config.save_nodes)
    check_trajectory_room(out / "traj-00000.h5", config.n_samples, nodes, len(setup.tendons),
                          setup.contact is not None, count=count)


def _execute(scenario, todo, out: Path, scheduler, n_workers, n_samples, dt=None):
    """Yield the indices as their files are finished."""
    tag = _fingerprint(f"{scenario.text}\n{n_samples}\n{dt}")
    tasks = [(run_variant, (scenario.text, scenario.source, i, str(trajectory_path(out, i)), n_samples, dt),
              f"softrnn-variant-{tag}-{i}") for i in todo]
    with closing(completed(tasks, scheduler, n_workers)) as results:
        for record in results:
            yield record["index"]

