"""The sequence model's options (``softrnn.lab.nets.Sequence``). Over a linear base (``linear``): a robot
whose dynamics are a lightly damped swing of its tip under its two inputs, seen through a mild
nonlinearity; the linear ARX model run free from rest (``families.LinearARXFamily``, ``from_rest``)
predicts every row from the first one alone; its order is chosen on a hold-out of the training rows;
the GRU over it leaves far less than the GRU alone on a session it never saw, and a refit keeps the
base's order. With the hysteresis state (``hysteresis``): a backlash the GRU alone cannot hold."""

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.families import LinearARXFamily, parsimonious, play
from softrnn.lab.nets import (
    LINEAR_ORDERS,
    Sequence,
    SequenceOptions,
    _lanes,
    linear_base,
    linear_first,
    sequence_candidates,
)
from softrnn.lab.recording import Recording
from softrnn.lab.synthetic import SyntheticOptions

DT = 0.05
"""The rows' interval [s] (20 Hz)."""


def _swing(u: np.ndarray, bend: float = 0.0) -> np.ndarray:
    """The tip (T, 3) [m] of a damped oscillator (1.3 Hz, damping ratio 0.03) in x and y driven by the
    inputs u (T, 2), exact zero-order-hold discretisation, from rest at the first row's equilibrium;
    ``bend`` [1/m]: the tip rises with the square of its swing (a pendulum's, 1 / (2 L)), so a linear
    model cannot hold it all."""
    w, z = 2 * np.pi * 1.3, 0.03
    A = np.array([[0.0, 1.0], [-w * w, -2 * z * w]])
    from scipy.linalg import expm

    M = expm(np.block([[A, np.array([[0.0], [w * w]])], [np.zeros((1, 3))]]) * DT)
    Ad, Bd = M[:2, :2], M[:2, 2]
    x = np.zeros((u.shape[1], 2))
    x[:, 0] = u[0]                                 # at rest, at the first row's equilibrium
    out = np.empty((len(u), 3))
    for k in range(len(u)):
        x = x @ Ad.T + np.outer(u[k], Bd)
        out[k, :2] = 0.05 * x[:, 0]
        out[k, 2] = -0.3 + bend * np.sum(out[k, :2] ** 2)
    return out


def _session(seed: int, rows: int = 600, bend: float = 0.0, path: str = "", noise: float = 0.0) -> Recording:
    """A recording of ``_swing``: a new pull of each input every 2 s, marker noise ``noise`` [m] per axis."""
    rng = np.random.default_rng(seed)
    steps = np.repeat(rng.uniform(-1, 1, (rows // 40 + 1, 2)), 40, axis=0)[:rows]
    tip = _swing(steps, bend) + rng.normal(0.0, noise, (rows, 3))
    return Recording(path=path, time=np.arange(rows) * DT, inputs=steps, names=("p0", "p1"), units=("bar", "bar"),
                     tip=tip)


def _rmse_mm(pred, s):
    return float(np.sqrt(np.mean(np.sum((pred - s.tip) ** 2, axis=1)))) * 1e3


def test_linear_model_from_rest_predicts_every_row_from_the_first():
    """An exact second-order system: the ARX model of order 2 fitted on one session reproduces another
    from its first row alone, the rows it would otherwise copy from the measurement included."""
    train, test = _session(0), _session(1)
    model = LinearARXFamily(2, 2, from_rest=True).fit([train])
    pred = model.predict(test)
    assert pred.shape == test.tip.shape
    assert _rmse_mm(pred, test) < 1e-6
    start = test.rows(0, 5)
    moved = Recording(path="", time=start.time, inputs=start.inputs, names=start.names, units=start.units,
                      tip=start.tip + np.array([0.0, 0.0, 1.0]))       # a wrong tip after the first row
    moved.tip[0] = start.tip[0]
    assert np.allclose(model.predict(moved), pred[:5], atol=1e-12)    # only the first row is read
    seeded = LinearARXFamily(2, 2).fit([train]).predict(moved)
    assert np.allclose(seeded[:2], moved.tip[:2])                      # without from_rest: the seed rows


def test_linear_base_order_is_chosen_on_a_hold_out_of_its_rows():
    """Orders are tried simplest first on a hold-out of the training sessions. With 0.1 mm of marker
    noise, the least-squares (equation error) model of order 2 runs free with a bias on the lightly
    damped swing; a higher order is chosen, whose free run over the held session is at the noise
    level (0.17 mm). Too few rows for the larger orders leave only the smallest; a given order is kept."""
    base, scores = linear_base([_session(0, noise=1e-4), _session(2, noise=1e-4)])
    assert list(scores) == [f"order={n}" for n in LINEAR_ORDERS]
    assert base.na == base.nb > 2 and base.from_rest
    assert scores[f"order={base.na}"] < 0.3 and scores["order=2"] > 2 * scores[f"order={base.na}"]
    kept, none = linear_base([_session(0)], order=8)
    assert (kept.na, none) == (8, {})
    short, scores = linear_base([_session(0, rows=60)])
    assert short.na == 2 and list(scores) == ["order=2"]


@pytest.fixture(scope="module")
def swing_models():
    train = [_session(0, bend=1.7, path="a"), _session(2, bend=1.7, path="b")]
    options = SequenceOptions(hidden=16, epochs=20, max_steps=600)
    return train, _session(5, bend=1.7), Sequence(options).fit(train), Sequence(options, linear=True).fit(train)


def test_gru_over_the_linear_base_learns_the_swing_the_gru_alone_misses(swing_models):
    """On a session it never saw, the GRU over the linear base is several times closer than the GRU
    alone (same network and training), and closer than its linear base by itself (the nonlinear part)."""
    _, test, alone, over = swing_models
    e_alone, e_over, e_base = _rmse_mm(alone.predict(test), test), _rmse_mm(over.predict(test), test), \
        _rmse_mm(over.base.predict(test), test)
    assert e_over < 0.3 * e_alone
    assert e_over < e_base
    details = over.describe()
    assert details["linear_order"] == over.base.na and "linear ARX" in details["kind"]
    assert "linear_order" not in alone.describe()


def test_refit_keeps_the_base_order_and_is_deterministic(swing_models):
    """A refit (the cross-fit's) refits the base with the order chosen at the fit; the same rows give
    the same model."""
    train, test, _, over = swing_models
    again = over.refit(train)
    assert again.base.na == over.base.na
    assert np.allclose(again.predict(test), over.predict(test), atol=1e-6)
    other = over.refit(train[:1])
    assert other.base.na == over.base.na and not np.allclose(other.base.arx.weights, over.base.arx.weights)


def test_sequence_candidates_simplest_first():
    """The hold-out tries the GRU without and with the hysteresis state first, then, with the state it
    chose, over the linear base, pretrained where there is synthetic data, and over the physics' tip
    where there is a calibrated physics."""
    assert sequence_candidates(SyntheticOptions(amount=0.0)) == {
        "hysteresis=False,mode=real": (False, "real", None), "hysteresis=True,mode=real": (True, "real", None)}
    assert list(sequence_candidates(SyntheticOptions(amount=0.0), True)) == ["hysteresis=True,mode=real,linear"]
    pretrained = sequence_candidates(SyntheticOptions(), False)
    assert pretrained["hysteresis=False,mode=finetune"] == (False, "finetune", None)
    assert list(sequence_candidates(SyntheticOptions(), True, physics=True)) == [
        "hysteresis=True,mode=real,linear", "hysteresis=True,mode=finetune", "hysteresis=True,mode=real,physics"]


def test_tie_keeps_the_linear_base():
    """Within one standard error of the best hold-out score (1 % over 5,000 rows), the GRU over a linear
    base is chosen before the GRU alone; beyond it, the better one; the other candidates keep their order."""
    alone, over = "hysteresis=False,mode=real", "hysteresis=False,mode=real,linear"
    tie = {alone: 4.69, "hysteresis=True,mode=real": 4.76, over: 4.73, "hysteresis=False,mode=finetune": 4.70}
    assert list(linear_first(tie)) == [over, alone, "hysteresis=True,mode=real", "hysteresis=False,mode=finetune"]
    assert parsimonious(tie, 5000) == alone
    assert parsimonious(linear_first(tie), 5000) == over
    assert parsimonious(linear_first(tie | {over: 4.80}), 5000) == alone
    assert parsimonious(linear_first(tie | {over: 1624.0}), 5000) == alone


def _backlash_session(seed: int, rows: int = 500) -> Recording:
    """A tip that follows its input through a backlash of width 0.3 (a play operator), quasi-static: the
    commands ramp to a new random target every 2 s, so the tip depends on the direction it came from."""
    rng = np.random.default_rng(seed)
    targets = rng.uniform(-1, 1, (rows // 40 + 2, 1))
    u = np.concatenate([np.linspace(a, b, 40, endpoint=False) for a, b in zip(targets[:-1], targets[1:])])[:rows]
    p = play(u, np.array([0.3]))
    tip = np.column_stack([0.05 * p[:, 0], np.zeros(rows), np.full(rows, -0.3)])
    return Recording(path=str(seed), time=np.arange(rows) * DT, inputs=u, names=("p0",), units=("bar",), tip=tip)


def test_the_hysteresis_state_lets_the_gru_hold_a_backlash():
    """With the play operators of its inputs among its inputs (``hysteresis``), the GRU holds a backlash
    on a session it never saw far better than the GRU of the commands alone (same network and training)."""
    train, test = [_backlash_session(0), _backlash_session(1)], _backlash_session(2)
    options = SequenceOptions(hidden=16, epochs=80, max_steps=600)
    alone, held = Sequence(options).fit(train), Sequence(options, hysteresis=True).fit(train)
    e_alone, e_held = _rmse_mm(alone.predict(test), test), _rmse_mm(held.predict(test), test)
    assert e_held < 0.5 * e_alone
    assert held.widths is not None and alone.widths is None and "hysteresis" in held.describe()["kind"]


def test_the_lanes_cover_every_row_once_in_whole_windows():
    """``_lanes``: each session cut into contiguous lanes of at most ``lane_windows`` windows, of about equal
    length, starting on a window's first row, that together hold each of its rows exactly once."""
    o = SequenceOptions(window=10, lane_windows=3)
    xs = [np.zeros((1, 95, 2)), np.zeros((1, 7, 2)), np.zeros((1, 30, 2))]
    lanes = _lanes(o, xs)
    for i, x in enumerate(xs):
        mine = [(a, b) for j, a, b in lanes if j == i]
        assert mine[0][0] == 0 and mine[-1][1] == x.shape[1]
        assert all(b == c for (_, b), (c, _) in zip(mine[:-1], mine[1:]))         # contiguous, no row twice
        assert all(a % o.window == 0 and b - a <= o.lane_windows * o.window for a, b in mine)
    assert [len([1 for j, _, _ in lanes if j == i]) for i in range(3)] == [4, 1, 1]
    with pytest.raises(SoftrnnInputError, match="lane_windows=0 is invalid"):
        SequenceOptions(lane_windows=0)
    with pytest.raises(SoftrnnInputError, match="state_runs=0 is invalid"):
        SequenceOptions(state_runs=0)
