"""The benchmark's kernels compiled ahead (``bench.simulator.warm_simulator``, which ``softrnn
reproduce`` runs in a background process while its first steps leave a core idle): the warm-ups run
exactly the configurations that the integrator and contact entries run first, so that the timed runs
find every kernel in numba's cache; and a case that fails is skipped, not raised."""

from softrnn.bench import _runs as bench_runs
from softrnn.bench import contact as bench_contact
from softrnn.bench import integrators as bench_integrators
from softrnn.bench import simulator as bench_simulator
from softrnn.rod import Simulator


def _recorded(monkeypatch, module) -> list:
    """Every ``Simulator(setup).run(config)`` of ``module`` and of the warm-up runs (``bench._runs``):
    (whether the setup has contact, config)."""
    runs = []

    class Recording(Simulator):
        def run(self, config, *args, **kwargs):
            runs.append((self.setup.contact is not None, config))
            return super().run(config, *args, **kwargs)

    monkeypatch.setattr(module, "Simulator", Recording)
    monkeypatch.setattr(bench_runs, "Simulator", Recording)
    return runs


def _first_runs(runs: list) -> list:
    """The warm-up runs among ``runs`` (2 samples), in order."""
    return [(contact, config) for contact, config in runs if config.n_samples == 2]


def test_the_integrator_warm_up_runs_what_the_timed_entries_run_first(monkeypatch):
    runs = _recorded(monkeypatch, bench_integrators)
    bench_integrators.time_integrators(1, 0.02, 50, cases=("square",))
    timed = _first_runs(runs)
    runs.clear()
    bench_integrators.warm_integrators(0.02, 50, cases=("square",))
    assert [config.integrator for _, config in runs] == [config.integrator for _, config in timed]
    assert runs == timed and len(runs) == len(bench_integrators.INTEGRATORS)
    runs.clear()
    bench_integrators.warm_integrators(0.02, 50, cases=("square",), integrators=("implicit",))
    assert runs == [run for run in timed if run[1].integrator.name == "implicit"] and len(runs) == 1


def test_the_contact_warm_up_runs_with_and_without_contact_as_the_timed_entry(monkeypatch):
    runs = _recorded(monkeypatch, bench_contact)
    bench_contact.time_contact_cases(1, 2_000, 0.01, cases=("contact-plane",))
    timed = _first_runs(runs)
    runs.clear()
    bench_contact.warm_contact_cases(2_000, 0.01, cases=("contact-plane",))
    assert runs == timed and [contact for contact, _ in runs] == [True, False]


def test_a_failing_case_is_skipped_and_the_settings_are_the_benchmarks(monkeypatch):
    bench_integrators.warm_integrators(0.02, 50, cases=("no-such-scenario",))      # skipped, not raised
    bench_contact.warm_contact_cases(2_000, 0.01, cases=("no-such-scenario",))
    called = []
    monkeypatch.setattr(bench_simulator, "warm_integrators",
                        lambda *a, integrators: called.append(("integrators", a, integrators)))
    monkeypatch.setattr(bench_simulator, "warm_contact_cases", lambda *a: called.append(("contact", a)))
    monkeypatch.setattr(bench_simulator, "warm_batch", lambda: called.append(("batch", ())))
    for quick in (True, False):
        called.clear()
        bench_simulator.warm_simulator(quick)
        *_, integrators, contact = bench_simulator._settings(quick)
        assert called == [("integrators", integrators[1:], ("implicit",)), ("contact", contact[1:]), ("batch", ()),
                          ("integrators", integrators[1:], ("explicit",))]          # every integrator, once
