"""Reproduce step: the paper's Fig. 14 hyper-parameter study (LSTM units x history: bandwidth and RMS
error) on the semicircle's node of interest, on Dask, under ``study/``."""

from pathlib import Path

from ..progress import ProgressFactory
from ..scenarios.cases import build_case
from .stepfiles import load_step, save_step

FIG14 = {"case": "semicircle", "units": (5, 10, 15, 20, 25), "history": (2, 5, 10, 20), "epochs": 10,
         "quick_units": (5, 20), "quick_history": (2, 10), "quick_epochs": 2}


def fig14_step(out: Path, quick: bool, progress_factory: ProgressFactory | None = None) -> dict:
    """The paper's Fig. 14 (LSTM units x history: bandwidth and RMS error) on the semicircle's node
    of interest, two Dask workers; a rerun completes only missing grid points."""
    from ..experiments.fig14 import StudyConfig, run_study  # optional extra: learn (PyTorch)

    step_file = out / "study" / "fig14-step.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    case = build_case(FIG14["case"])
    config = StudyConfig(node=case.node_of_interest, units=FIG14["quick_units" if quick else "units"],
                         history=FIG14["quick_history" if quick else "history"],
                         epochs=FIG14["quick_epochs" if quick else "epochs"])
    progress = progress_factory("Fig. 14 study") if progress_factory else None
    folder = out / "study" / ("fig14-quick" if quick else "fig14")
    result = run_study(out / "data" / f"{FIG14['case']}.h5", config, folder, workers=2, progress=progress)
    figure = out / "figures" / "fig14.png"
    figure.parent.mkdir(parents=True, exist_ok=True)
    figure.write_bytes(Path(result.figure).read_bytes())
    keep = ("units", "history", "bandwidth_hz", "torch_bandwidth_hz", "rmse_mm", "regions", "trends", "paper",
            "wall_seconds")
    summary = result.to_dict()
    kept = {k: summary[k] for k in keep}
    return save_step(step_file, {"case": FIG14["case"], "node": case.node_of_interest, "figure": "fig14.png",
                                 "folder": str(folder.relative_to(out)), **kept}, quick)
