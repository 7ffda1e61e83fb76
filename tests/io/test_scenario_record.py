"""The scenario record in dataset files (docs/dataset-format.md, "The scenario record"): a simulated
scenario's file carries what drove it, read back typed through ``softrnn.io.record``; the arrays are
those of a file without it; copies keep it; a file without it (written before it existed) loads as
before, and ``softrnn.scenarios.record.with_record`` rebuilds it from the stored text; a broken
record is a one-line error."""

import json
from dataclasses import replace

import h5py
import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import DatasetError, read_dataset, write_dataset
from softrnn.io.record import RECORD, ScenarioRecord, read_record, scenario_name
from softrnn.scenarios.record import with_record
from softrnn.scenarios.scenario import load_scenario
from softrnn.scenarios.summary import simulate_summary

from helpers import run_cli, without_record_builder


def _simulate(scenario, path, record):
    """``scenario`` (a sweep variant) simulated into ``path`` with the attrs a sweep writes."""
    config = replace(scenario.config, n_samples=4)
    attrs = {"variant_index": scenario.variant_index, "sampled": json.dumps(scenario.sampled)}
    simulate_summary(name=scenario.name, title=scenario.title, setup=scenario.setup, config=config,
                     node=scenario.nodes_of_interest[0], out_path=path, scenario_text=scenario.text,
                     seed=scenario.seed, attrs=attrs, record=record)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("record")
    variant = load_scenario("square").variant(2)
    _simulate(variant, root / "with.h5", variant.record)
    _simulate(variant, root / "plain.h5", None)          # the record of its text and draws
    assert read_dataset(root / "plain.h5").attrs[RECORD] == read_dataset(root / "with.h5").attrs[RECORD]
    with h5py.File(root / "plain.h5", "a") as f:   # a file as softrnn wrote it before the record
        del f.attrs[RECORD]
    return variant, root


def test_a_simulated_variant_carries_its_record(files):
    variant, root = files
    data = read_dataset(root / "with.h5")
    record = read_record(data)
    assert data.record.to_record() == record.to_record()
    assert isinstance(record, ScenarioRecord) and record.name == "square" == scenario_name(data)
    assert record.variant_index == 2 and record.sampled == json.loads(json.dumps(variant.sampled))
    assert record.nodes_of_interest == (50,) and record.paper == variant.paper and record.moving_clamps == ()
    (law,), (want,) = record.pd, [load for load in variant.setup.loads if type(load).__name__ == "PDTracking"]
    assert (law.node, law.stiffness, law.damping) == (want.node, want.stiffness, want.damping)
    t = np.linspace(0.0, 9.0, 91)
    np.testing.assert_array_equal(law.target(t), want.target(t))


def test_the_record_adds_an_attribute_only(files):
    _, root = files
    a, b = read_dataset(root / "with.h5"), read_dataset(root / "plain.h5")
    for name in ("time", "nodes", "positions", "quaternions", "forces", "torques"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.attrs["schema_version"] == b.attrs["schema_version"] == 2
    assert {k: v for k, v in a.attrs.items() if k != RECORD} == b.attrs


def test_an_older_file_loads_without_it_and_gets_it_back_from_its_text(files, tmp_path):
    _, root = files
    old = read_dataset(root / "plain.h5")
    with without_record_builder():          # as where softrnn.scenarios is not imported
        assert read_record(old) is None and old.record is None and RECORD not in old.attrs
    rebuilt = read_record(with_record(old))
    assert rebuilt.to_record() == read_record(read_dataset(root / "with.h5")).to_record()
    # softrnn.scenarios imported (as by every command): read_record rebuilds it from the text itself
    assert RECORD not in old.attrs and read_record(old).to_record() == rebuilt.to_record()
    assert old.record.to_record() == rebuilt.to_record()
    write_dataset(tmp_path / "copy.h5", read_dataset(root / "with.h5"))        # a copy keeps it
    assert read_dataset(tmp_path / "copy.h5").attrs[RECORD] == read_dataset(root / "with.h5").attrs[RECORD]


def test_an_older_file_is_upgraded_into_a_copy_with_the_record(files, tmp_path):
    from softrnn.io import list_groups, merge_files
    from softrnn.scenarios.record import upgrade_file

    _, root = files
    assert upgrade_file(root / "plain.h5", tmp_path / "new.h5") == 1
    new, plain = read_dataset(tmp_path / "new.h5"), read_dataset(root / "plain.h5")
    assert new.attrs[RECORD] == read_dataset(root / "with.h5").attrs[RECORD]
    assert {k: v for k, v in new.attrs.items() if k != RECORD} == plain.attrs
    np.testing.assert_array_equal(new.positions, plain.positions)
    merge_files([root / "plain.h5", root / "with.h5"], tmp_path / "sweep.h5")
    assert upgrade_file(tmp_path / "sweep.h5", tmp_path / "sweep-new.h5") == 1    # one had it already
    assert list_groups(tmp_path / "sweep-new.h5") == list_groups(tmp_path / "sweep.h5")
    assert all(read_dataset(tmp_path / "sweep-new.h5", group=g).record is not None
               for g in list_groups(tmp_path / "sweep-new.h5"))
    with pytest.raises(SoftrnnInputError, match="another file"):
        upgrade_file(root / "plain.h5", root / "plain.h5")


def test_a_sweep_writes_each_variants_record(tmp_path):
    out = tmp_path / "sweep"
    args = ["sweep", "square", "--count", "2", "--samples", "3", "--workers", "1", "-o", str(out), "--quiet"]
    assert run_cli(args) == 0
    records = [read_record(read_dataset(p)) for p in sorted(out.glob("*.h5"))]
    assert [r.variant_index for r in records] == [0, 1]
    assert records[0].pd[0].stiffness != records[1].pd[0].stiffness


def test_show_names_the_record_in_one_line(files, capsys):
    _, root = files
    assert run_cli(["show", str(root / "with.h5")]) == 0
    out = capsys.readouterr().out
    assert "scenario record: square, variant 2; 1 PD law(s), moving clamps none" in out
    assert "scenario_record=" not in out


def test_a_broken_record_is_one_line(files, tmp_path):
    _, root = files
    path = tmp_path / "broken.h5"
    path.write_bytes((root / "with.h5").read_bytes())
    with h5py.File(path, "a") as f:
        f.attrs[RECORD] = json.dumps({"version": 9, "name": "square"})
    with pytest.raises(DatasetError) as info:
        read_dataset(path)
    assert "\n" not in str(info.value) and "scenario record" in str(info.value)
