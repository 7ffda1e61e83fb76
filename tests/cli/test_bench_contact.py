"""``softrnn bench``'s contact entries (``simulator.contact``): a quick run of the shipped contact
scenarios through ``softrnn bench --only simulator --quick --json`` (the other simulator timings
replaced by stand-ins) has every key with finite, positive figures, the goal and the printed rows;
the run without contact takes the contact run's solver step. No timing is asserted (that is the
benchmark's job); the full bench runs in test_fresh_process."""

import json
import math
from types import SimpleNamespace

import pytest

from softrnn.bench import simulator as bench_simulator
from softrnn.bench.contact import CONTACT_CASES, CONTACT_KEYS, contact_configs, format_contact, time_contact
from softrnn.cli.main import main
from softrnn.rod import Clamp, RodSpec, RunConfig, Setup, Simulator, straight
from softrnn.scenarios import load_scenario


def _stand_ins(monkeypatch):
    """The single-rod, integrator, start-up, command start-up and batch timings replaced by fixed figures, so that only
    the contact part of the simulator benchmark runs for real."""
    row = dict(nodes=59, substeps=1, us_per_node_step=0.05, us_per_node_step_all_saved=0.06, realtime_factor=10.0,
               cpu_fraction=1.0)
    monkeypatch.setattr(bench_simulator, "time_single", lambda *a, **k: SimpleNamespace(to_dict=lambda: dict(row)))
    monkeypatch.setattr(bench_simulator, "time_integrators", lambda *a, tick=None, **k: {"how": "stand-in"})
    monkeypatch.setattr(bench_simulator, "time_compile", lambda *a: dict(cold_s=1.0, cached_s=0.1, import_s=0.05))
    monkeypatch.setattr(bench_simulator, "time_commands", lambda *a: {})
    monkeypatch.setattr(bench_simulator, "time_batch", lambda *a: dict(row, rods=16, threads=2))


def test_quick_bench_json_has_the_contact_figures(monkeypatch, tmp_path, capsys):
    _stand_ins(monkeypatch)
    path = tmp_path / "bench.json"
    assert main(["bench", "--only", "simulator", "--quick", "--quiet", "--json", str(path)]) == 0
    result = json.loads(path.read_text())
    contact = result["simulator"]["contact"]
    assert isinstance(contact["how"], str)
    assert set(contact) == set(CONTACT_CASES) | {"how"}
    for case in CONTACT_CASES:
        entry = contact[case]
        assert "error" not in entry, (case, entry)
        assert set(CONTACT_KEYS) <= set(entry)
        for key in ("us_per_node_step", "us_per_node_step_without_contact"):
            assert math.isfinite(entry[key]) and entry[key] > 0, (case, key, entry)
        # the overhead is a measured difference: finite, and consistent with the two costs
        assert math.isfinite(entry["overhead"]) and entry["overhead"] > -1.0
        ratio = entry["us_per_node_step"] / entry["us_per_node_step_without_contact"]
        assert entry["overhead"] == pytest.approx(ratio - 1.0)
        # the node-steps asked for, or the longest span allowed
        settings = result["simulator"]["settings"]["contact"]
        assert entry["simulated_s"] <= settings["max_span_s"] * 1.0001
        assert (entry["steps"] * entry["nodes"] >= settings["node_steps"]
                or entry["simulated_s"] == pytest.approx(settings["max_span_s"]))
    assert result["simulator"]["goals"]["contact_overhead"] == 0.30
    met = result["goals_met"]["simulator.contact_overhead"]
    assert met == (max(contact[c]["overhead"] for c in CONTACT_CASES) <= 0.30)
    printed = capsys.readouterr().out
    assert "contact, 1 thread" in printed and all(case in printed for case in CONTACT_CASES)


@pytest.mark.parametrize("case", CONTACT_CASES)
def test_the_run_without_contact_takes_the_contact_runs_step(case):
    scenario = load_scenario(case)
    bare, timed = contact_configs(scenario.setup, scenario.config, 3, node_steps=10**5, max_span_s=10.0)
    assert bare.contact is None and scenario.setup.contact is not None
    assert bare.rod is scenario.setup.rod and bare.boundary == scenario.setup.boundary
    automatic = Simulator(scenario.setup).resolve_substeps(scenario.config)
    assert timed.substeps == automatic == Simulator(bare).resolve_substeps(timed)
    assert timed.integrator == scenario.config.integrator and timed.save_nodes == (3,)
    per_sample = automatic * scenario.setup.rod.n_nodes   # node-steps per saved interval
    assert (timed.n_samples - 1) * per_sample >= 10**5 > (timed.n_samples - 2) * per_sample
    _, short = contact_configs(scenario.setup, scenario.config, 3, node_steps=10**12, max_span_s=0.05)
    assert short.n_samples == round(0.05 / scenario.config.dt) + 1
    _, whole = contact_configs(scenario.setup, scenario.config, 3, node_steps=10**12, max_span_s=100.0)
    assert whole.n_samples == scenario.config.n_samples


def test_a_setup_without_contact_is_refused_and_errors_are_printed():
    rod = RodSpec(length=0.3, radius=0.01, youngs_modulus=1e6, density=1000.0, n_nodes=5)
    setup = Setup(rod=rod, reference=straight(5, 0.3), boundary=(Clamp(0),))
    with pytest.raises(ValueError, match="setup.contact=None is invalid"):
        time_contact(setup, RunConfig(dt=1e-3, n_samples=10), 4, reps=1, node_steps=100, max_span_s=0.005)
    row = dict(us_per_node_step=0.2, us_per_node_step_without_contact=0.1, overhead=1.0, integrator="explicit",
               nodes=41, dt_s=7e-5, cpu_fraction=1.0)
    lines = format_contact({"contact-plane": row, "vessel-guidewire": {"error": "ValueError: x"}, "how": "..."},
                           0.30, False, {"contact": {"node_steps": 500_000, "max_span_s": 1.0}})
    text = "\n".join(lines)
    assert "MISS" in text and "100%" in text and "error: ValueError: x" in text and "first 1 s" in text
