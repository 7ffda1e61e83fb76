"""The field's tip metrics (``softrnn.learned.metrics``): the errors after removing the constant
offset between model and measurement over a session (opencr-mujoco's metric), and the coverage of a
stated uncertainty ball, checked by hand."""

import numpy as np
import pytest

from softrnn.learned.metrics import aligned_tip_errors, coverage, offset, tip_errors


def test_a_constant_offset_is_removed_and_nothing_else():
    rng = np.random.default_rng(0)
    ref = rng.normal(0, 0.02, (50, 3))
    wiggle = rng.normal(0, 1e-3, (50, 3))
    wiggle -= wiggle.mean(axis=0)                       # zero mean: the offset is exactly the shift
    shift = np.array([4e-3, -3e-3, 12e-3])
    pred = ref + shift + wiggle
    np.testing.assert_allclose(offset(pred, ref), shift, atol=1e-15)
    aligned, raw = aligned_tip_errors(pred, ref, 0.2), tip_errors(pred, ref, 0.2)
    by_hand = tip_errors(ref + wiggle, ref, 0.2)
    assert aligned.rmse_mm == pytest.approx(by_hand.rmse_mm) and aligned.mean_mm == pytest.approx(by_hand.mean_mm)
    assert raw.rmse_mm > 5 * aligned.rmse_mm
    assert aligned.pct_of_length(aligned.mean_mm) == pytest.approx(aligned.mean_mm / 200 * 100)
    assert tip_errors(pred, ref).pct_of_length(1.0) is None


def test_aligned_rmse_is_never_above_the_raw_one():
    """The mean is the offset that minimises the squared error: removing it never raises the RMSE."""
    rng = np.random.default_rng(1)
    for _ in range(20):
        ref, pred = rng.normal(0, 0.01, (30, 3)), rng.normal(0, 0.01, (30, 3)) + rng.normal(0, 0.01, 3)
        assert aligned_tip_errors(pred, ref).rmse_mm <= tip_errors(pred, ref).rmse_mm + 1e-12


def test_coverage_counts_the_rows_inside_the_ball():
    ref = np.zeros((4, 3))
    pred = np.array([[3e-3, 4e-3, 0], [1e-3, 0, 0], [0, 0, 0], [0, 0, 2e-3]])      # errors 5, 1, 0, 2 mm
    assert coverage(pred, ref, np.full(4, 2e-3)) == pytest.approx(0.75)             # the ball's edge counts
    assert coverage(pred, ref, np.array([5e-3, 0.5e-3, 0, 1e-3])) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="radius"):
        coverage(pred, ref, np.ones(3))


def test_per_pattern_alignment_removes_each_runs_own_offset():
    """With labels, each run of consecutive rows with one label loses its own offset: a prediction off
    by a different constant in each pattern is then exact, while one offset for the session is not;
    a label that comes back later is a new run."""
    rng = np.random.default_rng(2)
    ref = rng.normal(0, 0.02, (30, 3))
    labels = np.array(["a"] * 10 + ["b"] * 10 + ["a"] * 10)
    shifts = np.repeat([[1e-3, 0, 0], [0, -4e-3, 0], [0, 0, 7e-3]], 10, axis=0)
    pred = ref + shifts
    each = aligned_tip_errors(pred, ref, 0.2, groups=labels)
    assert each.rmse_mm == pytest.approx(0.0, abs=1e-12) and each.max_mm == pytest.approx(0.0, abs=1e-12)
    assert aligned_tip_errors(pred, ref, 0.2).mean_mm > 3.0
    with pytest.raises(ValueError, match="groups"):
        aligned_tip_errors(pred, ref, groups=labels[:5])
