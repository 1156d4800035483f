"""The origin-shift search of the linearised fit: the FFT form of the products with the shifted features equals
the shifted features formed explicitly (features.shift_measured), and the all-rows search finds the same δ as the
general one."""

import numpy as np

from rvflex.diagnosis import linear
from rvflex.diagnosis.features import shift_measured
from rvflex.diagnosis.plan import Layout


def _layout(K: int = 24) -> Layout:
    # two TE runs (mean, a_1…a_K, b_1…b_K each) and one torque cycle's 8 branch angles
    n = 2 * (1 + 2 * K) + 8
    return Layout(n=n, dc={0: 0, 1: 1 + 2 * K}, cos={0: slice(1, 1 + K), 1: slice(2 + 2 * K, 2 + 3 * K)},
                  sin={0: slice(1 + K, 1 + 2 * K), 1: slice(2 + 3 * K, 2 + 4 * K)}, hyst={2: slice(2 + 4 * K, n)},
                  max_order=K)


def test_shifted_products_equal_explicit_shift():
    lay = _layout()
    rng = np.random.default_rng(3)
    y, w = rng.normal(size=lay.n), rng.uniform(0.5, 2.0, size=lay.n)
    prob = linear.Problem.build(y, lay, w, np.zeros((lay.n, 0)))
    V = rng.normal(size=(lay.n, 4))
    grid = np.linspace(0.0, 2 * np.pi, linear.DELTA_GRID, endpoint=False)
    explicit = (V * w[:, None]).T @ shift_measured(y, lay, grid)
    # round-off of a 2048-point inverse FFT on O(10) sums: 1e-10 relative is far below any δ decision
    assert np.allclose(prob.shifted_products(V), explicit, rtol=0.0, atol=1e-10 * np.abs(explicit).max())


def test_all_rows_search_finds_the_true_origin():
    # a measured vector made from a model vector shifted by a known origin: both searches recover it
    lay = _layout()
    rng = np.random.default_rng(5)
    K = lay.max_order
    model = np.zeros(lay.n)
    for r in lay.te_runs:
        k = np.arange(1, K + 1)
        model[lay.cos[r]] = rng.normal(size=K) / k
        model[lay.sin[r]] = rng.normal(size=K) / k
    delta_true = 1.234
    measured = shift_measured(model, lay, -delta_true)[:, 0] + 1e-3 * rng.normal(size=lay.n)
    w = np.ones(lay.n)
    prob = linear.Problem.build(measured, lay, w, linear.nuisance_columns(lay))
    Q = np.linalg.qr(prob.nuis * w[:, None])[0]  # the searches project off the span of the fit's columns
    grid = np.linspace(0.0, 2 * np.pi, linear.DELTA_GRID, endpoint=False)
    fast = linear._best_delta_all_rows(prob, model, Q, grid)
    general = linear._best_delta(prob, model, Q, np.arange(lay.n), w, grid)
    step = 2 * np.pi / linear.DELTA_GRID
    assert fast == general
    assert abs((fast - delta_true + np.pi) % (2 * np.pi) - np.pi) <= step
