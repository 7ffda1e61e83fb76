"""Benchmarks on this machine (``softrnn bench``; scripts in ``benchmarks/``).

``run_all(parts)`` runs the learned-model (``bench.model``), simulator (``bench.simulator``),
static-solver (``bench.statics``), whole-manipulator-model (``bench.dynamic``) and
navigation-environment (``bench.envs``, optional extra ``envs``) measurements and returns one
JSON-ready dict::

    {"machine": {...}, "model": {...}, "simulator": {"cases": {...}, "integrators": {...}, ...},
     "statics": {...},
     "dynamic": {"cases": {...}, ...}, "envs": {...}, "paper": {...}, "goals_met": {...}, "settings": {...}}

``format_all`` renders it as text. Neither prints.
"""

from __future__ import annotations

from ..progress import Progress
from ..timing import load_average, machine_info
from .dynamic import format_dynamic_table, run_dynamic_benchmark
from .simulator import PAPER, format_table, run_benchmark
from .statics import format_static_table, run_static_benchmark


def run_all(parts=("model", "simulator", "statics", "dynamic"), *, quick: bool = False, model=None,
            dynamic_configs: dict | None = None, dynamic_models: dict | None = None,
            progress: Progress | None = None) -> dict:
    """Run the selected parts in this order: model, simulator, statics, dynamic, envs (each after the
    last, so none competes with another for a core). ``model``: the node model to time (default: a
    synthetic one); ``dynamic_configs`` ({case: DynamicConfig}) the whole-manipulator models' stand-in
    architecture, ``dynamic_models`` ({case: LoadedDynamic}) trained ones timed instead."""
    result: dict = {"machine": machine_info(), "settings": {"quick": bool(quick), "parts": list(parts),
                                                          "load_average_start": load_average()}}
    paper = {"source": PAPER["source"], "hardware": PAPER["hardware"]}
    goals_met: dict = {}
    if "model" in parts:
        from .model import PAPER as MODEL_PAPER  # optional extra: learn (PyTorch)
        from .model import run_model_benchmark  # optional extra: learn (PyTorch)
        result["model"] = run_model_benchmark(quick=quick, model=model, progress=progress)
        paper["rnn_bandwidth_hz"] = MODEL_PAPER["rnn_bandwidth_hz"]
        goals_met.update({f"model.{k}": v for k, v in result["model"]["goals_met"].items()})
    if "simulator" in parts:
        sim = run_benchmark(quick=quick, progress=progress)
        result["simulator"] = sim["simulator"]
        result["simulator"]["goals"] = sim["goals"]
        result["simulator"]["settings"] = sim.get("settings", {})
        paper["analytical_model_us_per_node_step"] = sim["paper"]["us_per_node_step"]
        goals_met.update({f"simulator.{k}": v for k, v in sim["goals_met"].items()})
    if "statics" in parts:
        result["statics"] = run_static_benchmark(quick=quick)
        paper["static_solver_hz"] = list(result["statics"]["paper"]["bandwidth_hz"])
        goals_met["statics.warm_solves_per_s"] = bool(result["statics"]["goal"]["met"])
        if progress is not None:
            progress(1, 1)
    if "dynamic" in parts:
        result["dynamic"] = run_dynamic_benchmark(quick=quick, configs=dynamic_configs, models=dynamic_models,
                                                  progress=progress)
        goals_met.update({f"dynamic.{k}": v for k, v in result["dynamic"]["goals_met"].items()})
    if "envs" in parts:
        from .envs import run_envs_benchmark  # optional extra: envs (gymnasium)
        result["envs"] = run_envs_benchmark(quick=quick)
        goals_met["envs.vector_speedup"] = result["envs"]["goal"]["met"]
        if progress is not None:
            progress(1, 1)
    result["paper"] = paper
    result["goals_met"] = goals_met
    result["settings"]["load_average_end"] = load_average()
    return result


def format_all(result: dict) -> str:
    """Text tables of ``run_all``'s result."""
    m = result["machine"]
    out = [f"machine: {m['cpu']}, {m['usable_cores']} usable cores, {m['platform']}; load average "
           f"{result['settings'].get('load_average_start')} -> {result['settings'].get('load_average_end')}"]
    if "model" in result:
        from .model import format_model_table  # optional extra: learn (PyTorch)
        out += ["", format_model_table(result["model"])]
    if "simulator" in result:
        sim = {"machine": m, "simulator": result["simulator"], "goals": result["simulator"]["goals"],
               "paper": {"source": result["paper"]["source"], "hardware": result["paper"]["hardware"],
                         "us_per_node_step": result["paper"]["analytical_model_us_per_node_step"]},
               "goals_met": {k.split(".", 1)[1]: v for k, v in result["goals_met"].items()
                             if k.startswith("simulator.")},
               "settings": result["simulator"].get("settings", {})}
        out += ["", format_table(sim)]
    if "statics" in result:
        out += ["", format_static_table(result["statics"])]
    if "dynamic" in result:
        out += ["", format_dynamic_table(result["dynamic"])]
    if "envs" in result:
        from .envs import format_envs_table  # optional extra: envs (gymnasium)
        out += ["", format_envs_table(result["envs"])]
    return "\n".join(out)
