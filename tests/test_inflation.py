"""The noise-inflation shrinkage every likelihood uses
(:func:`bayescal.core.model.inflation.shrunk_inflation`), against its closed form."""
import numpy as np

from bayescal.core.model.inflation import INFLATION_SHRINK, shrunk_inflation


def test_shrinkage_toward_the_pooled_value():
    raw = np.array([1.0, 3.0])
    # equal weights to the shrinkage weight: halfway to the pooled value 2
    np.testing.assert_allclose(shrunk_inflation(raw, INFLATION_SHRINK), [1.5, 2.5], rtol=1e-15)
    # per-band weights: (w raw + S pooled) / (w + S)
    w = np.array([150.0, 0.0])
    np.testing.assert_allclose(shrunk_inflation(raw, w), [(150 + 100) / 200, 2.0], rtol=1e-15)


def test_floor_at_a_thousandth_of_the_pooled_value():
    raw = np.array([-2000.0, 0.0, 5000.0])      # pooled 1000, the first band shrinks to -500
    np.testing.assert_allclose(shrunk_inflation(raw, INFLATION_SHRINK), [1.0, 500.0, 3000.0])
    # a pooled value at or below zero: floored at 1e-3 of the pooled_floor instead
    assert shrunk_inflation(np.zeros(2), 10.0, pooled_floor=1e-12)[0] == 1e-15


def test_lag_one_scatter_counts_only_overlapping_neighbours():
    """Segments starting at 0, 50, 100, 300 (length 100): the pairs (0, 1)
    and (1, 2) overlap, (2, 3) does not. With the product as quadratic form
    and residuals 1, 2, 3, 4: q0 = 1 + 4 + 9 + 16 = 30, q1 = 2 + 6 = 8, so
    q0 + 2 q1 = 46."""
    from bayescal.core.model.inflation import lag_one_scatter, overlapping_segments

    adjacent = overlapping_segments(np.array([0, 50, 100, 300]), 100)
    np.testing.assert_array_equal(adjacent, [0, 1])
    r = np.array([[1.0], [2.0], [3.0], [4.0]])              # (K, B=1)
    scatter = lag_one_scatter(lambda x, y: (x * y).sum(axis=0), r, adjacent)
    np.testing.assert_array_equal(scatter, [46.0])
    # independent segments (no overlap): the plain sum of squares
    none = overlapping_segments(np.array([0, 100, 200, 300]), 100)
    np.testing.assert_array_equal(lag_one_scatter(lambda x, y: (x * y).sum(axis=0), r, none),
                                  [30.0])
