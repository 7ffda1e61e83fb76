"""The one settings check every resumable part uses (``softrnn.resume``): the record's JSON round
trip, the differing setting named in one line, allowed differences, files of earlier releases."""

import json
import math
from dataclasses import dataclass

import numpy as np
import pytest

from softrnn import __version__
from softrnn.errors import SoftrnnInputError
from softrnn.reproduce.stepfiles import load_step, save_step
from softrnn.resume import REFUSE, RESUME, START_AGAIN, Difference, Settings, check

NOW = {"spec": {"node": 2, "neighbours": (1, 3), "history": 2}, "model": {"units": 8},
       "train": {"epochs": 4, "patience": 8, "seed": 0, "lr": 0.002}, "data": "abc123", "pool": None}
RESUMABLE = ("train.epochs", "train.patience")


def _record(values=NOW, may_differ=RESUMABLE):
    return Settings.of(values, may_differ=may_differ, opaque={"data": "the training data differ"})


def _with(path: str, value) -> dict:
    """A deep copy of ``NOW`` with the dotted ``path`` set to ``value``."""
    d = json.loads(json.dumps(NOW))
    *parents, leaf = path.split(".")
    node = d
    for key in parents:
        node = node[key]
    node[leaf] = value
    return d


def test_the_record_round_trips_through_json():
    s = _record()
    stored = json.loads(json.dumps(s.to_json()))
    assert s.like(stored) == s
    assert check(stored, s) == RESUME
    assert stored["spec"]["neighbours"] == [1, 3] and "epochs" not in stored["train"]   # plain, without may_differ
    assert list(stored) == list(NOW)                                                   # the caller's order kept


def test_a_dataclass_gives_the_same_record_as_its_dict():
    @dataclass(frozen=True)
    class Config:
        units: int = 8
        rate: float = 0.5
        sizes: tuple = (1, 2)

    assert Settings.of(Config()) == Settings.of({"units": 8, "rate": 0.5, "sizes": [1, 2]})
    assert Settings.of({"x": np.float64(0.25), "n": np.int64(3)}).values == {"x": 0.25, "n": 3}


def test_a_differing_setting_is_named_with_its_old_and_new_value():
    then = _record(_with("train.seed", 1)).to_json()

    def refuse(diff: Difference) -> SoftrnnInputError:
        return SoftrnnInputError(f"m: checkpoint.pt was written with other settings ({diff}); resume with the same "
                                 f"settings, or train without --resume to start again")

    with pytest.raises(SoftrnnInputError) as err:
        check(then, _record(), otherwise=REFUSE, refuse=refuse)
    text = str(err.value)
    assert "train.seed: 1 then, 0 now" in text and "\n" not in text
    with pytest.raises(SoftrnnInputError, match=r"spec.history: 3 then, 2 now.*start again"):
        check(_with("spec.history", 3), _record())                                    # the default error
    assert check(then, _record(), otherwise=START_AGAIN) == START_AGAIN


def test_the_first_difference_in_sorted_order_with_fingerprints_last_and_said_in_words():
    then = _with("data", "other")
    then["spec"]["history"] = 3
    then["model"]["units"] = 9
    diff = _record().difference(_record(then))
    assert (diff.key, diff.old, diff.new, str(diff)) == ("model.units", 9, 8, "model.units: 9 then, 8 now")
    assert str(_record().difference(_record(_with("data", "other")))) == "the training data differ"
    nested = Settings.of({"config": {"a": 1}, "data": {"train": [1], "heldout": [2]}},
                         opaque={"data": "the {name} data differ"})
    stored = {"config": {"a": 1}, "data": {"train": [1], "heldout": [3]}}
    assert str(nested.difference(nested.like(stored))) == "the heldout data differ"


def test_an_allowed_difference_is_accepted_and_others_are_not():
    assert check(_with("train.epochs", 40), _record()) == RESUME                       # extending: allowed
    assert check(_with("train.patience", 2), _record()) == RESUME
    finished = _record(may_differ=("train.patience",))                                 # a finished run: epochs count
    with pytest.raises(SoftrnnInputError, match=r"train.epochs: 40 then, 4 now"):
        check(_with("train.epochs", 40), finished)


def test_a_file_of_an_earlier_release_is_accepted():
    old = {"spec": {"node": 2, "neighbours": [1, 3], "history": 2}, "model": {"units": 8},
           "train": {"seed": 0, "lr": 0.002}, "data": "abc123"}                       # no pool key, lists
    assert check(old, _record()) == RESUME
    manifest = {"scenario": "semicircle", "source": "x.toml", "scenario_sha256": "f00", "seed": 3, "n_samples": 11,
                "dt": None, "softrnn_version": "0.0.1"}                               # more keys than are settings
    now = Settings.of(dict(manifest, softrnn_version=__version__), keys=("dt", "n_samples", "scenario_sha256", "seed"))
    assert check(manifest, now) == RESUME
    with pytest.raises(SoftrnnInputError, match="dt: None then, 0.01 now"):
        check(manifest, Settings.of(dict(manifest, dt=0.01), keys=now.keys))


@pytest.mark.parametrize("stored", [None, [], "text", {}])
def test_nothing_readable_stored_is_never_resumed(stored):
    now = Settings.of({"a": 1})
    assert check(stored, now, otherwise=START_AGAIN) == START_AGAIN
    with pytest.raises(SoftrnnInputError):
        check(stored, now)


def test_a_nan_setting_matches_itself():
    now = Settings.of({"a": math.nan, "b": [1.0, math.nan]})
    assert check(json.loads(json.dumps(now.to_json())), now) == RESUME


@pytest.mark.parametrize("kwargs, word", [({"otherwise": "retry"}, "otherwise="), ({"now": {"a": 1}}, "now=")])
def test_bad_arguments_are_one_line_errors(kwargs, word):
    args = {"then": {"a": 1}, "now": Settings.of({"a": 1}), **kwargs}
    with pytest.raises(SoftrnnInputError, match=word):
        check(args.pop("then"), **args)
    with pytest.raises(SoftrnnInputError, match="settings="):
        Settings.of([1, 2])
    with pytest.raises(SoftrnnInputError, match="may_differ="):
        Settings.of({"a": 1}, may_differ="a")


def test_a_step_file_of_this_version_is_reused_and_any_other_is_not(tmp_path):
    path = tmp_path / "step.json"
    written = save_step(path, {"value": np.float64(1.5)}, quick=True)
    assert list(written)[:2] == ["quick", "softrnn_version"] and load_step(path, True) == written
    assert load_step(path, False) is None
    path.write_text(json.dumps({"quick": True, "softrnn_version": "0.0.1", "value": 1.5}))  # an earlier release's
    assert load_step(path, True) is None
    path.write_text("[1, 2]")
    assert load_step(path, True) is None
