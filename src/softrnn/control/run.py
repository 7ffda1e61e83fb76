"""A closed-loop run written out: the plant's record as a dataset (``run.h5``, for ``softrnn
animate``), the figure (``control.png``: reference and measured angles, currents) and the summary
(``control.json``: ``ControlSummary``)."""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..figures.saving import save_figure, subplots
from ..files import atomic_write_bytes, atomic_write_text
from ..io.reader import Dataset
from ..io.writer import write_dataset
from ..magnetics.manipulator import ManipulatorSpec
from ..progress import Progress
from .controllers import controller as make_controller
from .identify import identified_model
from .loop import LoopConfig, LoopResult, LoopSummary, run_loop
from .model import NarxModel
from .references import reference as make_reference

RUN_FILE = "run.h5"
MODEL_FILE = "control-model.npz"
FIGURE_FILE = "control.png"
SUMMARY_FILE = "control.json"
TRACE_FILE = "trace.npz"


@dataclass(frozen=True)
class ControlSummary:
    """The summary of a control run (``SUMMARY_FILE``): what ran, the loop's figures and where the
    files are.

    Attributes
    ----------
    reference, controller : str
        their names
    duration_s : float
        the reference's last time [s]
    loop : LoopSummary
        the loop's figures
    config : LoopConfig
        the plant and camera
    run_file, figure_file : str
        paths of ``RUN_FILE`` and ``FIGURE_FILE``
    """

    reference: str
    controller: str
    duration_s: float
    loop: LoopSummary
    config: LoopConfig
    run_file: str
    figure_file: str

    def to_dict(self) -> dict:
        """JSON-ready: reference, controller, duration_s, the loop's figures, config and files."""
        return {"reference": self.reference, "controller": self.controller, "duration_s": self.duration_s,
                **self.loop.to_dict(), "config": self.config.to_dict(),
                "files": {"run": self.run_file, "figure": self.figure_file}}


def write_run(path, result: LoopResult, config: LoopConfig, attrs: dict) -> None:
    """The plant's record as a softrnn dataset (every node; orientations are not kept: identity
    placeholders), the currents and the reference in its attrs."""
    spec = config.plant_spec(ManipulatorSpec())
    T, n = result.positions.shape[:2]
    quats = np.zeros((T, n, 4), np.float32)
    quats[..., 0] = 1.0
    zeros = np.zeros((T, n, 3), np.float32)
    meta = {"has_orientations": False, "currents": result.currents.tolist(), "currents_units": "A, coils 0..5",
            "reference_deg": np.degrees(result.reference).tolist(), "rod": spec.rod_spec(),
            "dt": 1.0 / config.rate, **attrs}
    data = Dataset(time=result.time, nodes=np.arange(n), positions=result.positions.astype(np.float32),
                   quaternions=quats, forces=zeros, torques=zeros, attrs=meta)
    write_dataset(path, data)


def plot_run(result: LoopResult, title: str):
    """Reference and measured distal angles about y and x, and the six currents, against time."""
    fig, axes = subplots(3, 1, figsize=(10, 7.5), sharex=True)
    meas = np.degrees(result.measured[:, 1, :2])
    true = np.degrees(result.true[:, 1, :2])
    ref = np.degrees(result.reference)
    for ax, c, name in ((axes[0], 1, "about y (bending)"), (axes[1], 0, "about x (out of plane)")):
        ax.plot(result.time, ref[:, c], color="k", lw=1.2, label="reference")
        ax.plot(result.time, meas[:, c], color="tab:blue", lw=0.6, alpha=0.6, label="measured (camera)")
        ax.plot(result.time, true[:, c], color="tab:blue", lw=1.0, label="true")
        ax.set_ylabel(f"distal {name} [deg]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    axes[2].plot(result.time, result.currents, lw=0.8)
    axes[2].set_ylabel("coil currents [A]")
    axes[2].set_xlabel("t [s]")
    axes[2].grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def learned_model(out_dir, model_path=None, *, identify_seconds: float = 90.0, config: LoopConfig | None = None,
                  seed: int = 0, steps: int = 2000, progress: Progress | None = None):
    """The MPC's NARX model: read from ``model_path``, or from ``out_dir/MODEL_FILE`` when an earlier
    run left it there with the same identification settings, or identified on the plant of
    ``config`` and trained now (then saved there). ``progress``: the identification's and the
    training's (``identified_model``); not called when the model is read."""
    if model_path is not None:
        return NarxModel.load(model_path)
    config = LoopConfig() if config is None else config
    path = Path(out_dir) / MODEL_FILE
    want = {"identification_seconds": float(identify_seconds), "plant": config.to_dict(), "seed": seed,
            "steps": int(steps)}
    if path.exists():
        try:
            model = NarxModel.load(path)
            if model.meta.get("settings") == want:
                return model
        except Exception:                                                         # noqa: BLE001 - remade below
            pass
    model = identified_model(seconds=identify_seconds, config=config, seed=seed, steps=steps, progress=progress)
    model.meta["settings"] = want
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    model.save(path)
    return model


def control_run(reference: str, controller: str, out_dir, *, duration: float = 60.0, config: LoopConfig | None = None,
                model=None, spec=None, progress: Progress | None = None) -> ControlSummary:
    """Run ``controller`` on ``reference`` for ``duration`` s and write ``RUN_FILE``, ``FIGURE_FILE``,
    ``SUMMARY_FILE`` and ``TRACE_FILE`` (time, reference, true and measured orientations, currents)
    into ``out_dir``; returns the summary. ``model``: the ``NarxModel`` of ``mpc-learned``; ``spec``:
    the ``ManipulatorSpec`` the controller takes as its model (None: the nominal one)."""
    config = LoopConfig() if config is None else config
    ref = make_reference(reference, duration=duration, rate=config.rate, seed=config.seed)
    ctrl = make_controller(controller, spec, model=model, config=config)
    result = run_loop(ctrl, ref, config, progress=progress)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = ControlSummary(reference=ref.name, controller=controller, duration_s=float(ref.times[-1]),
                             loop=result.summary(), config=config, run_file=str(out / RUN_FILE),
                             figure_file=str(out / FIGURE_FILE))
    write_run(out / RUN_FILE, result, config, {"controller": controller, "reference": ref.name})
    buf = io.BytesIO()
    np.savez(buf, time=result.time, reference=result.reference, true=result.true, measured=result.measured,
             currents=result.currents)
    atomic_write_bytes(out / TRACE_FILE, buf.getvalue())
    rms = "not finite" if summary.loop.rms_deg is None else f"{summary.loop.rms_deg:.2f} deg"
    save_figure(plot_run(result, f"{controller} on the {ref.name} reference: RMS {rms}"), out / FIGURE_FILE)
    atomic_write_text(out / SUMMARY_FILE, json.dumps(summary.to_dict(), indent=2, allow_nan=False) + "\n")
    return summary


def run_one(reference: str, controller: str, out_dir: str, duration: float, config: dict,
            model=None) -> ControlSummary:
    """``control_run`` with a plain-dict ``config`` (``LoopConfig`` fields), for a Dask worker."""
    return control_run(reference, controller, out_dir, duration=duration, config=LoopConfig(**config), model=model)
