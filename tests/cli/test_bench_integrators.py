"""``softrnn bench``'s integrator entries (``simulator.integrators``) on a tiny rod: the keys, finite
numbers, the reference error and the fixed-step fallback of a stiff wire, and the printed table. No
timing is asserted (that is the benchmark's job); the full bench runs in test_fresh_process."""

import math

import pytest

from softrnn.bench.integrators import (
    INTEGRATORS,
    KEYS,
    REFERENCE_REFINE,
    format_integrators,
    integrator_configs,
    time_integrator,
)
from softrnn.rod import Clamp, Damping, RodSpec, RunConfig, Setup, Simulator, straight


def _rod(n=5, youngs_modulus=1e6, radius=0.01, tau=0.0):
    rod = RodSpec(length=0.3, radius=radius, youngs_modulus=youngs_modulus, density=1000.0, n_nodes=n)
    shape = straight(n, rod.length, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    return Setup(rod=rod, reference=shape, boundary=(Clamp(0),), gravity=(0.0, 0.0, -9.81),
                 damping=Damping(kelvin_voigt=tau))


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_entry_has_finite_figures_and_a_reference_error(integrator):
    setup = _rod()
    entry = time_integrator(setup, RunConfig(dt=2e-3, n_samples=100), 4, integrator, reps=1, span_s=0.02,
                            fixed_steps=100)
    assert set(KEYS) <= set(entry)
    for key in KEYS:
        assert math.isfinite(entry[key]) and entry[key] >= 0, (key, entry[key])
    assert entry["us_per_node_step"] > 0 and entry["real_time_factor"] > 0
    assert entry["reference_dt_s"] == pytest.approx(entry["dt_s"] / REFERENCE_REFINE)
    assert entry["simulated_s"] == pytest.approx(0.02)
    assert entry["tip_error_pct_of_length"] < 1.0   # a sagging tip, resolved by both steps


def test_stiff_explicit_wire_is_timed_over_fixed_steps_without_reference():
    steel = _rod(n=21, youngs_modulus=200e9, radius=0.0008, tau=1e-4)
    config = RunConfig(dt=1e-3, n_samples=2001)
    h, timed, reference, reason = integrator_configs(steel, config, 20, "explicit", 0.3, 1000)
    assert reference is None and "reference" in reason
    assert timed.substeps == 1000 and timed.n_samples == 2 and timed.dt / 1000 <= h
    h_imp, timed_imp, reference_imp, reason_imp = integrator_configs(steel, config, 20, "implicit", 0.3, 1000)
    assert reason_imp is None and h_imp > 1e4 * h
    assert timed_imp.substeps is None   # timed at the automatic step
    assert reference_imp.substeps == REFERENCE_REFINE * Simulator(steel).resolve_substeps(timed_imp)


def test_table_lists_every_case_and_the_reason_for_a_missing_error():
    row = dict(us_per_node_step=0.1, dt_s=1e-4, real_time_factor=12.0, tip_error_pct_of_length=0.01, tip_node=20,
               cpu_fraction=1.0)
    integrators = {"explicit": {"steel-wire": dict(row, tip_error_pct_of_length=None, tip_error_reason="too stiff")},
                   "implicit": {"steel-wire": row, "ellipse": {"error": "ValueError: x"}}, "how": "..."}
    text = "\n".join(format_integrators(integrators, {"integrators": {"span_s": 0.3, "fixed_steps": 20000}}))
    assert "steel-wire" in text and "ellipse" in text and "too stiff" in text and "error: ValueError" in text
