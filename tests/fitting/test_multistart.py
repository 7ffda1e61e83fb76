"""The calibration core's fit from several starts: the best start refined, a resumed fit refining its
given point alone, and the records of what was tried."""

import numpy as np
import pytest

from softrnn.fitting import StartOptions, multistart


def _residual(x):
    # two minima in x[0] (at -1 and +2, the deeper at +2), a line in x[1]
    return np.array([(x[0] + 1.0) * (x[0] - 2.0), 0.1 * (x[0] - 2.0), x[1] - 3.0])


def _rms(fun):
    return float(np.sqrt(np.mean(fun ** 2)))


def test_the_best_start_is_refined_and_every_start_recorded():
    starts = [({"start": "left"}, np.array([-1.5, 0.0])), ({"start": "right"}, np.array([2.5, 0.0]))]
    calls = []
    found = multistart(_residual, starts, (np.full(2, -np.inf), np.full(2, np.inf)),
                       options=StartOptions(quick_evaluations=20, evaluations=50, refine=1), score=_rms, key="rms",
                       progress=lambda done, total: calls.append((done, total)))
    np.testing.assert_allclose(found.x, [2.0, 3.0], atol=1e-6)
    assert found.score < 1e-6 and calls == [(1, 3), (2, 3), (3, 3)]
    assert [e["start"] for e in found.tried] == ["left", "right"]
    assert "refined_rms" in found.tried[1] and "refined_rms" not in found.tried[0]


def test_a_resumed_fit_refines_its_point_alone():
    free = (np.full(2, -np.inf), np.full(2, np.inf))
    found = multistart(_residual, [({"start": "left"}, np.array([-1.5, 0.0]))], free, options=StartOptions(),
                       score=_rms, resume=({"start": "given"}, np.array([1.8, 2.0])))
    assert [e["start"] for e in found.tried] == ["given"] and np.isnan(found.tried[0]["score"])
    np.testing.assert_allclose(found.x, [2.0, 3.0], atol=1e-6)


def test_a_screen_carries_on_only_the_best_starts():
    """Screened: every start recorded with its screen score, only the best ``screen_keep`` fitted on
    (they alone have the quick score) and the best of those refined; progress counts every fit."""
    starts = [({"start": name}, np.array([x0, 0.0])) for name, x0 in (("far left", -4.0), ("left", -1.5),
                                                                      ("right", 2.5), ("far right", 6.0))]
    calls = []
    found = multistart(_residual, starts, (np.full(2, -np.inf), np.full(2, np.inf)),
                       options=StartOptions(quick_evaluations=20, evaluations=50, refine=1, screen_evaluations=3,
                                            screen_keep=2),
                       score=_rms, key="rms", progress=lambda done, total: calls.append((done, total)))
    np.testing.assert_allclose(found.x, [2.0, 3.0], atol=1e-6)
    assert [e["start"] for e in found.tried] == ["far left", "left", "right", "far right"]
    assert all("screen_rms" in e for e in found.tried) and sum("rms" in e for e in found.tried) == 2
    kept = sorted(found.tried, key=lambda e: e["screen_rms"])[:2]
    assert all("rms" in e for e in kept) and sum("refined_rms" in e for e in found.tried) == 1
    assert calls == [(k, 7) for k in range(1, 8)]


def test_a_screen_needs_evaluations():
    from softrnn.errors import SoftrnnInputError

    with pytest.raises(SoftrnnInputError, match="screen_evaluations"):
        StartOptions(screen_keep=2)


def test_spread_pieces_give_the_same_fit_to_the_bit():
    """Each stage cut into interleaved pieces (as a pool's workers would run them) gives the same
    point, scores and records as the fits one by one; the spread sees each stage once."""
    starts = [({"start": k}, np.array([x0, 0.5 * k])) for k, x0 in enumerate((-4.0, -1.5, 0.3, 2.5, 6.0))]
    options = StartOptions(quick_evaluations=6, evaluations=30, refine=2, screen_evaluations=2, screen_keep=3)
    free = (np.full(2, -np.inf), np.full(2, np.inf))
    one = multistart(_residual, starts, free, options=options, score=_rms, key="rms")
    stages = []

    def spread(stage, fn, arguments):
        stages.append((stage, [len(a[1]) for a in arguments]))
        return [fn(*a) for a in reversed(arguments)][::-1]       # any order of running

    calls = []
    two = multistart(_residual, starts, free, options=options, score=_rms, key="rms", spread=spread, pieces=2,
                     progress=lambda done, total: calls.append((done, total)))
    assert np.array_equal(one.x, two.x) and one.score == two.score
    for a, b in zip(one.tried, two.tried, strict=True):
        assert a.keys() == b.keys() and np.array_equal(a["x"], b["x"])
        assert all(a[k] == b[k] for k in a if k != "x")
    assert stages == [("screen", [3, 2]), ("fit", [2, 1]), ("refine", [1, 1])]
    assert calls == [(5, 10), (8, 10), (10, 10)]
