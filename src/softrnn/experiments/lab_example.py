"""Lab-like example data: the simulated three-tendon arm recorded as a motion-capture session.

A real lab sees a tendon-driven rod through a few markers and its actuator readings, not the whole
simulated state. ``write_lab_example`` runs a shipped tendon scenario (by default ``tendon-spatial``,
smooth random tensions, and ``tendon-spatial-sine``, sinusoidal tensions, for a generalisation
check) and keeps what such a session would give:

* one marker at the tip (``n40_x``, ``n40_y``, ``n40_z`` [m]): the position only, no orientation,
  with Gaussian marker noise of standard deviation ``noise`` per axis (default 0.3 mm, a typical
  optical motion-capture figure), written to 1 µm;
* the three tendon tensions as actuation channels ``act_tendon_a[N]`` .. ``act_tendon_c[N]``: the
  tensions the simulator applied (what a load cell in each tendon reads), written to 0.1 mN;
* at ``rate`` samples per second (default 20 Hz), instantaneous samples of the simulation.

The files are in the layout of ``softrnn import-csv`` (docs/csv-format.md), with comment lines that
record the command that regenerates them. Everything is computed here (nothing is downloaded), and
the same arguments give byte-identical files on the same machine: the simulator is deterministic and
the noise is drawn by ``numpy.random.default_rng([seed, k])`` for the k-th scenario.
"""

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import bad, integer, is_finite_number, positive
from ..files import atomic_write_text, check_room, size_text
from ..progress import Progress
from ..rod import Simulator
from ..rod.simulation import SAMPLE_VALUES, array_limit
from ..rod.tendons import tension_matrix
from ..scenarios import load_scenario

#: The scenarios written by default: training data and a generalisation record.
DEFAULT_SCENARIOS = ("tendon-spatial", "tendon-spatial-sine")


@dataclass(frozen=True)
class LabExampleConfig:
    """What the example recording holds.

    ``scenarios``: shipped tendon scenarios (or paths to scenario files with ``[[tendons]]``), one CSV
    each, named ``<scenario name>.csv``; ``duration`` [s] of each recording (from t = 0, the rod at
    rest); ``rate`` [Hz], samples per second; ``noise`` [m], the standard deviation of the marker
    noise per axis (0: none); ``seed``, the noise's seed; ``node``, the marker's node (negative:
    from the tip; default the tip)."""

    scenarios: tuple = DEFAULT_SCENARIOS
    duration: float = 600.0
    rate: float = 20.0
    noise: float = 3e-4
    seed: int = 0
    node: int = -1

    def __post_init__(self):
        if isinstance(self.scenarios, (str, bytes)) or not hasattr(self.scenarios, "__iter__"):
            raise bad("scenarios", self.scenarios, "a sequence of scenario names or paths, e.g. ('tendon-spatial',)")
        object.__setattr__(self, "scenarios", tuple(str(s) for s in self.scenarios))
        if not self.scenarios:
            raise bad("scenarios", list(self.scenarios), "at least one scenario, e.g. tendon-spatial")
        positive("rate", self.rate, "Hz")
        positive("duration", self.duration, "s")
        if self.duration * self.rate < 10:
            raise bad("duration", self.duration, f"at least 10 samples: a duration >= {10 / self.rate:g} s at "
                                                 f"{self.rate:g} Hz")
        if not is_finite_number(self.noise) or self.noise < 0 or self.noise > 0.01:
            raise bad("noise", self.noise, "a marker noise in m in [0, 0.01] (e.g. 3e-4 for 0.3 mm)")
        integer("seed", self.seed, 0)
        if not isinstance(self.node, int) or isinstance(self.node, bool):
            raise bad("node", self.node, "an integer node index (negative: from the tip)")


def _tendon_scenario(scenario):
    """The loaded scenario (name, path or ``Scenario``), checked to have tendons."""
    sc = load_scenario(scenario) if isinstance(scenario, (str, Path)) else scenario
    if not sc.setup.tendons:
        raise bad("scenarios", sc.name, "scenarios with [[tendons]] (e.g. tendon-spatial): the example records "
                                        "tendon tensions")
    return sc


def samples(config: LabExampleConfig) -> int:
    """The samples of each recording of ``config`` (t = 0 .. ``duration`` at ``rate``)."""
    return int(round(config.duration * config.rate)) + 1


def _run_config(sc, config: LabExampleConfig):
    """The run of a loaded tendon scenario ``sc`` that a recording of ``config`` makes."""
    node = sc.setup.node_index(config.node, "node")
    return replace(sc.config, dt=1.0 / config.rate, n_samples=samples(config), save_nodes=(node,))


def record(scenario, config: LabExampleConfig, index: int = 0, progress: Progress | None = None) -> dict:
    """Simulate ``scenario`` (a name, path or loaded ``Scenario`` with tendons) and sample it like
    the lab: returns ``name``, ``node`` (absolute index), ``n_nodes``, ``time`` (T,) [s],
    ``positions`` (T, 3) [m] of the marker with noise, ``clean`` (T, 3) [m] without, ``tensions``
    (T, m) [N] and ``channels`` (the m tendon names). ``progress``: the simulator's
    (``progress(samples_done, samples(config))`` after every chunk of samples)."""
    sc = _tendon_scenario(scenario)
    node = sc.setup.node_index(config.node, "node")
    dt = 1.0 / config.rate
    run = _run_config(sc, config)
    chunks = []
    Simulator(sc.setup).run(run, progress=progress, sink=chunks.append)
    clean = np.concatenate([c.positions[:, 0] for c in chunks])
    time = dt * np.arange(clean.shape[0])
    rng = np.random.default_rng([config.seed, index])
    noisy = clean + config.noise * rng.standard_normal(clean.shape)
    return {"name": sc.name, "node": node, "n_nodes": sc.setup.rod.n_nodes, "time": time, "positions": noisy,
            "clean": clean, "tensions": tension_matrix(sc.setup.tendons, time),
            "channels": tuple(td.name for td in sc.setup.tendons)}


def csv_text(rec: dict, config: LabExampleConfig, command: str = "") -> str:
    """The CSV (import-csv layout) of a ``record``: comment lines (what it is, ``command``), the
    header, one row per sample."""
    node = rec["node"]
    lines = [f"# Lab-like example recording (softrnn.experiments.lab_example): the simulated arm '{rec['name']}' "
             f"({rec['n_nodes']} nodes),",
             f"# one tip marker (node {node}, position only) with {config.noise * 1e3:g} mm noise per axis "
             f"(seed {config.seed}), the tendon tensions [N], {config.rate:g} Hz, {config.duration:g} s."]
    if command:
        lines.append(f"# generated by: {command}")
    header = ["time", f"n{node}_x", f"n{node}_y", f"n{node}_z"]
    header += [f"act_tendon_{c}[N]" for c in rec["channels"]]
    lines.append(",".join(header))
    for t, p, f in zip(rec["time"], rec["positions"], rec["tensions"]):
        lines.append(f"{t:.4f}," + ",".join(f"{v:.6f}" for v in p) + "," + ",".join(f"{v:.4f}" for v in f))
    return "\n".join(lines) + "\n"


def csv_row_bytes(config: LabExampleConfig, n_channels: int) -> int:
    """Bytes of one row of a recording's CSV (``csv_text``): the time, three coordinates and
    ``n_channels`` tensions with their commas (a generous width for each number)."""
    return len(f"{config.duration:.4f}") + 3 * 11 + n_channels * 10 + 3 + n_channels + 1


def _check_size(out: Path, config: LabExampleConfig, scenarios) -> None:
    """Refuse up front, before any run, recordings too large for this machine: runs too long
    (``Simulator.check_size``), recordings that would not fit its memory (each is held whole while
    it is made) or the free disk of ``out`` (``files.check_room``)."""
    for sc in scenarios:
        Simulator(sc.setup).check_size(_run_config(sc, config), streamed=True)
    n = samples(config)
    rows = [n * csv_row_bytes(config, len(sc.setup.tendons)) for sc in scenarios]
    fix = "use a lower --rate or a shorter --duration"
    held = max(rows) + n * (SAMPLE_VALUES + 4) * 8      # one recording's text and its samples
    if held > array_limit():
        raise bad("rate", config.rate, f"a recording that fits this machine's memory: {config.duration:g} s at "
                                       f"{config.rate:g} Hz ({n} samples) is too large, it would hold about "
                                       f"{size_text(held)} (limit {size_text(array_limit())}); {fix}")
    check_room(out / f"{scenarios[0].name}.csv", sum(rows),
               f"{len(rows)} recording{'s' if len(rows) > 1 else ''} of {n} rows "
               f"({config.duration:g} s at {config.rate:g} Hz)", fix)


def write_lab_example(out_dir, config: LabExampleConfig | None = None, *, command: str = "",
                      overwrite: bool = False, progress: Progress | None = None) -> list[Path]:
    """Write one CSV per scenario of ``config`` into ``out_dir`` (created if needed), each
    atomically; returns their paths. An existing CSV is replaced only with ``overwrite``.
    ``progress(done, total, {"scenario": name})`` counts the simulated samples of every scenario
    as one total (``samples(config)`` per scenario), reported after every chunk of each run."""
    config = config or LabExampleConfig()
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise bad("out_dir", str(out), "a folder (this is a file); choose another path")
    scenarios = [_tendon_scenario(s) for s in config.scenarios]    # every one checked before any run
    paths = [out / f"{sc.name}.csv" for sc in scenarios]
    if len(set(paths)) != len(paths):
        raise bad("scenarios", list(config.scenarios), "scenarios with distinct names (one CSV each)")
    if not overwrite:
        for p in paths:
            if p.exists():
                raise bad("out_dir", str(out), f"a folder without {p.name} (it exists; pass overwrite=True to "
                                               "replace it)")
    _check_size(out, config, scenarios)
    n, total = samples(config), samples(config) * len(scenarios)

    def part(k: int, name: str):
        if progress is None:
            return None
        return lambda done, _total, info=None: progress(k * n + done, total, {"scenario": name})

    made = not out.exists()
    try:
        for k, (sc, p) in enumerate(zip(scenarios, paths)):
            atomic_write_text(p, csv_text(record(sc, config, k, part(k, sc.name)), config, command))
    except BaseException:       # a full disk, Ctrl-C: the finished recordings stay, an empty new folder goes
        if made and out.is_dir() and not any(out.iterdir()):
            out.rmdir()
        raise
    return paths
