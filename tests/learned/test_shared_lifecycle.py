"""The learned family's shared folder and checkpoint code: one folder error for both kinds of model,
the JSON header checks, the records read from a folder, a rollout's metadata, and the lifecycle of a
training folder whose settings sit beside its checkpoint."""

import json

import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.learned.artifacts import ModelFolderError, check_format, from_fields, open_folder, read_json
from softrnn.learned.checkpoints import CHECKPOINT, SETTINGS, TrainingFolder, output_folder
from softrnn.learned.rollout import predicted_attrs
from softrnn.resume import Settings


def test_both_kinds_raise_the_one_folder_error():
    from softrnn.learned.node.artifact import ModelFolderError as NodeError
    from softrnn.learned.whole.artifact import DynamicFolderError

    assert NodeError is ModelFolderError and DynamicFolderError is ModelFolderError
    assert issubclass(ModelFolderError, SoftrnnInputError)


def test_a_folder_is_checked_before_its_files(tmp_path):
    with pytest.raises(ModelFolderError, match="no such model folder; train one with 'x -o"):
        open_folder(tmp_path / "missing", made_by="'x'", train=f"'x -o {tmp_path / 'missing'}'")
    (tmp_path / "file").write_text("")
    with pytest.raises(ModelFolderError, match="is a file, not a model folder"):
        open_folder(tmp_path / "file", made_by="'x'", train="'x'")
    with pytest.raises(ModelFolderError, match="a.json is missing"):
        read_json(tmp_path, "a.json")
    (tmp_path / "a.json").write_text("{")
    with pytest.raises(ModelFolderError, match="a.json is corrupt"):
        read_json(tmp_path, "a.json")


@pytest.mark.parametrize("doc, unversioned, words", [
    ({"format": "other", "format_version": 1}, False, "format='other', expected 'mine'"),
    ({"format": "mine", "format_version": "1"}, False, "format_version='1'"),
    ({"format": "mine"}, False, "format_version=None"),
    ({"format": "mine", "format_version": 3}, False, "newer than this softrnn reads (2)"),
    ([1], False, "format='list'"),
])
def test_a_header_of_another_format_or_version_is_one_line(tmp_path, doc, unversioned, words):
    with pytest.raises(ModelFolderError, match=words.replace("(", r"\(").replace(")", r"\)")) as err:
        check_format(tmp_path, "m.json", doc, "mine", 2, what="test model", made_by="'x'", unversioned=unversioned)
    assert "\n" not in str(err.value) and str(tmp_path) in str(err.value)


def test_an_unversioned_header_is_version_zero(tmp_path):
    assert check_format(tmp_path, "m.json", {"format": "mine"}, "mine", 1, what="m", made_by="'x'",
                        unversioned=True) == {"format": "mine"}


def test_records_are_read_from_dicts_of_their_fields():
    from dataclasses import dataclass

    @dataclass(frozen=True)
    class Rec:
        a: int
        b: tuple = ()

    assert from_fields(Rec, {"a": 1, "b": [2, 3]}, "rec", tuples=("b",)) == Rec(1, (2, 3))
    with pytest.raises(SoftrnnInputError, match=r"^rec='list' is invalid: a dict of Rec fields"):
        from_fields(Rec, [1], "rec")
    with pytest.raises(SoftrnnInputError, match=r"^rec=\['a', 'c'\] is invalid: the Rec fields"):
        from_fields(Rec, {"a": 1, "c": 2}, "rec")


def test_a_prediction_keeps_the_references_metadata_but_what_it_drops():
    attrs = {"schema_version": 2, "scenario_name": "square", "seed": 3}
    out = predicted_attrs(attrs, ("schema_version",), {"scenario_name": "square (predicted)", "prediction": True})
    assert out == {"scenario_name": "square (predicted)", "seed": 3, "prediction": True}
    assert list(out) == ["scenario_name", "seed", "prediction"] and attrs["scenario_name"] == "square"


def test_a_training_folder_refuses_foreign_files(tmp_path):
    folder = tmp_path / "busy"
    folder.mkdir()
    (folder / "thesis.tex").write_text("precious")
    with pytest.raises(SoftrnnInputError, match=r"holds other files \(thesis.tex\)"):
        output_folder(folder, holds=("model.json",), overwrite=True, ours={"model.json"}, made_by="'x'")
    assert output_folder(tmp_path / "new", holds=("model.json",), overwrite=False) == tmp_path / "new"


def test_a_training_folder_records_its_settings_and_discards_a_failed_start(tmp_path):
    folder = tmp_path / "run"
    run = TrainingFolder(folder, Settings.of({"config": {"steps": 5}}), created=True)
    run.start(resume=False)
    assert json.loads((folder / SETTINGS).read_text())
    assert not run.kept() and not folder.exists()            # no checkpoint came: nothing is left
    run.start(resume=False)
    (folder / CHECKPOINT).write_bytes(b"state")
    assert run.kept() and (folder / SETTINGS).is_file()
    other = TrainingFolder(folder, Settings.of({"config": {"steps": 6}}))
    with pytest.raises(SoftrnnInputError, match=r"^resume=True is invalid: the settings of the checkpoint"):
        other.start(resume=True)
    read = []
    run.start(resume=True, read=read.append)
    assert read == [folder / CHECKPOINT]
    with pytest.raises(SoftrnnInputError, match="the settings of the finished model"):
        run.check_finished({"config": {"steps": 7}})
