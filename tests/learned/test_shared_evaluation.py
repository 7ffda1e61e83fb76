"""What both kinds of learned model share: the horizons, the free-running evaluator by horizon
(the same numbers for a node model's table and the whole model's on uniform motion, where
persistence lags by the distance travelled), the typed results' JSON (``to_dict``, key order) and
the span check's one-line errors."""

import json

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.learned import baselines, horizons, spans
from softrnn.learned.baselines import ConstantVelocity, Persistence, StateBaseline, free_run
from softrnn.learned.horizons import (
    HORIZON_STARTS,
    HORIZONS,
    WHOLE_HORIZON_STARTS,
    WHOLE_HORIZONS,
    HorizonRow,
    HorizonTable,
    free_steps,
    worst_by_horizon,
)
from softrnn.learned.node.data import SampleSpec
from softrnn.learned.node.evaluate import BaselineComparison, compare_baselines, evaluate, horizon_table
from softrnn.learned.whole import evaluation
from softrnn.learned.whole.encoding import make_encoding

from helpers import LENGTH, Oracle, chain_dataset, node_dataset

STEP_M = 2.0 ** -10          # uniform motion along x, m per sample (exact in float32)


def _uniform(T: int = 200, n: int = 9):
    """A straight rod of ``n`` nodes translating along x by STEP_M per sample: positions (T, n, 3)."""
    x0 = np.zeros((n, 3))
    x0[:, 0] = np.arange(n) / 16.0
    return x0[None] + np.arange(T)[:, None, None] * np.array([STEP_M, 0.0, 0.0])


def test_one_horizons_definition():
    assert HORIZONS == (1, 10, 100, 1000)
    assert WHOLE_HORIZONS == (10, 100, 1000) and evaluation.HORIZONS == WHOLE_HORIZONS
    assert baselines.horizon_errors.__defaults__[0] == HORIZONS
    assert HORIZON_STARTS == 5 and WHOLE_HORIZON_STARTS == evaluation.HORIZON_STARTS == 4
    assert horizons.horizon_table.__defaults__[:2] == (HORIZONS, HORIZON_STARTS)


def test_both_kinds_give_the_same_numbers_for_persistence_on_uniform_motion():
    pos = _uniform()
    runs = {"model": lambda p, w, s, e: free_run(ConstantVelocity(), p, w, s, e),
            "persistence": lambda p, w, s, e: free_run(Persistence(), p, w, s, e)}
    node = horizon_table(runs, pos, None, 5, pos.shape[0], (10, 100), n_starts=3, length=LENGTH).to_dict()
    # the whole model at its model step = one sample: every node is STEP_M * n off after n steps
    dt = 2.0 ** -7
    ds = chain_dataset(pos, np.tile([1.0, 0, 0, 0], pos.shape[:2] + (1,)), dt)
    enc = make_encoding([ds], model_dt=dt, node_stride=2, length=LENGTH)
    persistence = StateBaseline(Persistence())
    whole = evaluation.compare({"persistence": persistence}, enc, [(enc.trajectory(ds), ds)], (10, 100)).to_dict()
    for h in (10, 100):
        expected = 100.0 * h * STEP_M / LENGTH                         # % of the rod's length
        assert node[str(h)]["persistence"] == pytest.approx(expected, rel=1e-12)
        assert whole[str(h)]["persistence"] == pytest.approx(expected, rel=1e-9)
        assert node[str(h)]["model"] == pytest.approx(0.0, abs=1e-12)  # constant velocity is exact
    cv = evaluation.compare({"cv": StateBaseline(ConstantVelocity())}, enc, [(enc.trajectory(ds), ds)], (10,))
    assert cv.to_dict()["10"]["cv"] == pytest.approx(0.0, abs=1e-9)


def test_the_simple_baselines_step_states_of_any_width_alike():
    hist = np.arange(2 * 4 * 6, dtype=np.float64).reshape(2, 4, 6)
    assert np.array_equal(StateBaseline(Persistence()).step(hist, None)[0], hist[-1])
    assert np.array_equal(StateBaseline(ConstantVelocity()).step(hist, None)[0], 2 * hist[-1] - hist[-2])
    assert StateBaseline(Persistence()).history == StateBaseline(ConstantVelocity()).history == 2
    with pytest.raises(SoftrnnInputError, match="baseline="):
        StateBaseline("persistence")


def test_worst_by_horizon_spreads_starts_and_leaves_out_what_does_not_fit():
    seen = []

    def error(span, start, h):
        seen.append((span, start, h))
        return np.inf if (span, start) == (1, 12) else float(start + h)

    out = worst_by_horizon(error, [(2, 30), (3, 15)], (5, 20, 40), 3)
    assert out[5].starts == ((2, 14, 25), (3, 6, 10)) and out[5].error == 30.0
    assert out[20].starts == ((2, 6, 10), ()) and out[20].error == 30.0   # 3 + 20 > 15: the second span is left out
    assert out[40] is None
    assert (1, 12, 5) not in seen
    assert worst_by_horizon(error, [(2, 30), (12, 15)], (3,), 1)[3].error == np.inf   # a diverged run: inf
    assert worst_by_horizon(lambda s, t, h: np.inf, [(0, 9)], (2,), 2)[2].error == np.inf


def test_free_steps_stops_where_the_run_diverges():
    state = np.zeros((6, 2))
    state[:2] = [[1.0, 1.0], [2.0, 2.0]]
    k = free_steps(lambda k, w: None if w[-1, 0] > 3 else w[-1] + w[-2], state, 2)
    assert k == 4 and state[2].tolist() == [3.0, 3.0] and state[3].tolist() == [5.0, 5.0]
    assert state[4:].tolist() == [[0.0, 0.0]] * 2


# ------------------------------------------------------------------------------------- typed results
def test_horizon_tables_to_dict_keep_the_reports_key_order():
    node = HorizonTable(kind="at", names=("model",), n_starts=2,
                        rows=(HorizonRow(1, {"model": 1e-3}, (3, 4)), HorizonRow(10, None)))
    d = node.to_dict()
    assert d == {"unit": "mm", "n_starts": 2, "1": {"model": 1.0}, "10": None, "max_abs_mm": {"1": {"model": 1.0},
                 "10": None}, "starts": {"1": [3, 4], "10": None}}
    assert list(d) == ["unit", "n_starts", "1", "10", "max_abs_mm", "starts"]
    assert list(d["max_abs_mm"]) == list(d["starts"]) == ["1", "10"]
    assert json.loads(json.dumps(d)) == d
    whole = HorizonTable(kind="within", names=("model", "persistence"),
                         rows=(HorizonRow(10, {"model": np.inf, "persistence": 2.0}),
                               HorizonRow(100, {"model": 3.0, "persistence": 4.0})))
    assert whole.to_dict() == {"10": {"model": None, "persistence": 2.0}, "100": {"model": 3.0, "persistence": 4.0}}
    assert list(whole.to_dict()) == ["10", "100"]


def test_a_dynamic_evaluation_writes_only_what_was_evaluated_in_order():
    span = {"model": {"max_pct_of_length": 1.5, "diverged_at": None, "steps": 3}}
    e = evaluation.DynamicEvaluation(model_dt_s=0.02, predicted_nodes=5, nodes=9, length_m=0.5, history=3,
                                     test_span={"start_s": 0.0, "end_s": 1.0, **span}, heldout=None, horizons=None,
                                     generalisation=span)
    d = e.to_dict()
    assert list(d) == ["model_dt_s", "predicted_nodes", "nodes", "length_m", "history", "test_span",
                       "test_span_max_pct_of_length", "generalisation", "generalisation_max_pct_of_length"]
    assert d["test_span_max_pct_of_length"] == d["generalisation_max_pct_of_length"] == 1.5
    held = evaluation.DynamicEvaluation(model_dt_s=0.02, predicted_nodes=5, nodes=9, length_m=0.5, history=3,
                                        test_span=None, heldout={"variants": 1},
                                        horizons=HorizonTable(kind="within", names=("model",),
                                                              rows=(HorizonRow(10, {"model": 1.0}),)),
                                        generalisation=None)
    assert list(held.to_dict())[-2:] == ["heldout", "horizons"] and held.to_dict()["horizons"] == {"10": {"model": 1.0}}
    assert json.loads(json.dumps(d)) == d


def test_a_node_evaluation_is_typed_and_its_dict_keeps_the_report_layout():
    ds = node_dataset(T=80)
    oracle = Oracle(ds, SampleSpec(node=2, history=2, wrench="wrench"))
    ev = evaluate(oracle, ds)
    d = ev.to_dict()
    assert d == ev.to_json() and list(d)[-5:] == ["free_running", "paper", "baselines", "horizons", "misses"]
    assert isinstance(ev.horizons, HorizonTable) and d["horizons"] == ev.horizons.to_dict()
    assert list(d["horizons"])[:2] == ["unit", "n_starts"] and list(d["horizons"])[-2:] == ["max_abs_mm", "starts"]
    compared = compare_baselines(oracle, ds, 48, 80, length=LENGTH)
    assert isinstance(compared, BaselineComparison)
    assert list(compared.to_dict()) == ["baselines", "horizons"]
    assert list(compared.to_dict()["baselines"]) == ["persistence", "constant_velocity", "linear"]
    assert json.loads(json.dumps(d)) == d


# ------------------------------------------------------------------------------------- span check
SPAN_ERRORS = {
    "start before the history": (lambda: spans.check_span(30, 2, 1, 10), "start=1", "a sample "
                                 "index in 2..29: the history = 2 samples before it are the first window"),
    "stop past the record": (lambda: spans.check_span(30, 2, 5, 31, targets=2), "stop=31", "a "
                             "sample index in 7..30 (at least 2 predicted sample(s) after start=5)"),
    "not an integer": (lambda: spans.check_span(30, 2, 2.0, 10), "start=2.0", "a sample index "
                       "(integer)"),
    "rollout wording": (lambda: spans.check_span(30, 2, 5, 5, wording=spans.SEEDS), "stop=5",
                        "a sample index in [6, 30] (after start=5)"),
    "short record": (lambda: spans.check_length(2, 2, "x.h5"), "x.h5 has 2 samples but the model's history is 2: "
                     "it needs at least 3 (the history and one sample to predict); use a longer record or a "
                     "shorter history"),
    "short fit": (lambda: spans.check_fit_span(30, 2, 10, 13, 2), "stop=13", "a training span "
                  "[start, stop) = [10, 13) of at least history + 2 = 4 samples"),
    "model step": (lambda: spans.check_step_start(0, 3, 10), "start=0", "a model step in [2, 8] "
                   "(history 3, 10 steps)"),
    "trained part": (lambda: spans.check_beyond_trained(3, 2, 20, 21, fraction=0.15, path="a.h5"),
                     "--test-start=0.15", "a start after the trained part of a.h5 (its first 20 "
                     "samples): a fraction >= 0.45"),
}


@pytest.mark.parametrize("case", sorted(SPAN_ERRORS))
def test_the_span_check_errors_are_one_line(case):
    call, *words = SPAN_ERRORS[case]
    with pytest.raises(SoftrnnInputError) as err:
        call()
    assert all(w in str(err.value) for w in words) and "\n" not in str(err.value)


def test_a_good_span_passes_and_the_test_span_starts_where_every_predictor_can():
    assert spans.check_span(30, 2, np.int64(2), 30) == (2, 30)
    assert spans.check_fit_span(30, 2, 0, 30, 2) == (0, 30)
    assert spans.check_step_start(2, 3, 10) == 2
    spans.check_beyond_trained(10, 2, 20, 21, fraction=0.5, path="a.h5")   # (10 + 1) * 2 >= 20: unseen
    assert spans.start_of_test_span(2, 101, 0.6) == 60 and spans.start_of_test_span(5, 3, 0.6) == 5
    assert horizons.spread_starts(5, 10, 3) == [5, 8, 10]
