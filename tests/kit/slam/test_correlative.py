"""The correlative matcher's compiled search, held to the plain algorithms it speeds up: its
coarse tables to scipy's maximum filter, and its branch and bound (which skips sub-blocks that
cannot win) to a branch and bound that scores every offset of every block it opens — the same
answer to the bit, ties included. The matcher's accuracy is tested in
``test_scan_matching.py``."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import maximum_filter

from kit.slam import correlative


def scipy_coarse(values, f):
    """``C[r + f − 1, c + f − 1] = max(L[r : r + f, c : c + f])``, by scipy."""
    return maximum_filter(np.pad(values, f - 1), size=f, origin=-(f // 2), mode="constant",
                          cval=0.0)


@pytest.mark.parametrize("factor", [1, 2, 3, 4, 5, 8])
def test_coarse_tables_equal_scipys_maximum_filter_to_the_bit(factor):
    rng = np.random.default_rng(factor)
    values = rng.uniform(0.0, 1.0, (37, 23)) * (rng.uniform(size=(37, 23)) < 0.3)
    field = correlative.LikelihoodField(values, np.zeros(2), 0.05)
    table = field.coarse(factor)
    expected = scipy_coarse(values, factor)
    assert table.shape == expected.shape == (37 + 2 * factor - 2, 23 + 2 * factor - 2)
    assert table.tobytes() == expected.tobytes()
    assert field.coarse(factor) is table  # kept with the field


def plain_branch_and_bound(values, coarse, ix, iy, half, f, angle_penalty, linear_penalty):
    """Blocks best bound first, every offset of an opened block scored in the block's order
    (dx, then dy), the first strictly better score kept; sums over the points in order."""
    k_count, m = ix.shape
    starts = np.arange(-half, half + 1, f)
    nb = len(starts)
    ch, cw = coarse.shape
    h, w = values.shape
    sums = np.zeros((k_count, nb, nb))
    for k in range(k_count):
        for j in range(m):
            for b in range(nb):
                cy = iy[k, j] + f - 1 + starts[b]
                for a in range(nb):
                    cx = ix[k, j] + f - 1 + starts[a]
                    if 0 <= cy < ch and 0 <= cx < cw:
                        sums[k, b, a] += coarse[cy, cx]
    bound = np.empty(k_count * nb * nb)
    for k in range(k_count):
        for a in range(nb):
            for b in range(nb):
                ox, oy = starts[a], starts[b]
                nx = 0 if ox <= 0 < ox + f else min(abs(ox), abs(ox + f - 1))
                ny = 0 if oy <= 0 < oy + f else min(abs(oy), abs(oy + f - 1))
                pen = angle_penalty[k] - linear_penalty * (nx * nx + ny * ny)
                bound[(k * nb + a) * nb + b] = sums[k, b, a] / m * max(pen, 0.0)
    best = (k_count // 2, 0, 0, -1.0)
    for n in np.argsort(-bound):
        if bound[n] <= best[3]:
            break
        k = n // (nb * nb)
        ox, oy = starts[(n // nb) % nb], starts[n % nb]
        for dx in range(ox, min(ox + f, half + 1)):
            for dy in range(oy, min(oy + f, half + 1)):
                total = 0.0
                for j in range(m):
                    cx, cy = ix[k, j] + dx, iy[k, j] + dy
                    if 0 <= cy < h and 0 <= cx < w:
                        total += values[cy, cx]
                pen = angle_penalty[k] - linear_penalty * (dx * dx + dy * dy)
                if pen > 0.0 and total / m * pen > best[3]:
                    best = (k, dx, dy, total / m * pen)
    return best


@pytest.mark.parametrize("factor", [1, 2, 3, 4, 8])
@pytest.mark.parametrize("levels", [None, 3])
def test_branch_and_bound_answers_as_scoring_every_offset_of_its_blocks_ties_included(
        factor, levels):
    """Random fields (``levels``: values on three levels, so many poses score alike), points
    partly off the field, with and without a penalty: the compiled search's angle, offset
    and score are the plain branch and bound's, to the bit."""
    rng = np.random.default_rng(10 * factor + (levels or 0))
    search = correlative._compiled()[2]
    for trial in range(6):
        h, w = rng.integers(15, 40, 2)
        values = rng.uniform(0.0, 1.0, (h, w))
        if levels:
            values = np.floor(values * levels) / levels
        field = correlative.LikelihoodField(values, np.zeros(2), 0.05)
        m, k_count, half = int(rng.integers(5, 30)), int(rng.integers(1, 6)), int(
            rng.integers(1, 9))
        ix = rng.integers(-5, w + 5, (k_count, m))
        iy = rng.integers(-5, h + 5, (k_count, m))
        penalty = 0.0 if trial % 2 else 0.3
        angle_penalty = 1.0 - penalty * np.linspace(-1, 1, k_count) ** 2
        linear_penalty = penalty / half**2
        g = (factor + 1) // 2
        got = search(values, field.coarse(factor), field.coarse(g), ix, iy, half, factor, g,
                     angle_penalty, linear_penalty)
        expected = plain_branch_and_bound(values, field.coarse(factor), ix, iy, half, factor,
                                          angle_penalty, linear_penalty)
        assert tuple(got[:3]) == tuple(expected[:3])
        assert np.float64(got[3]).tobytes() == np.float64(expected[3]).tobytes()
