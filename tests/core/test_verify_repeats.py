"""A swept cutter (and a forest of them) asked the same point more than once searches it once:
the repeats are found bit for bit (the same coordinates and member only), and every row's
figures are those of the point asked on its own."""

from __future__ import annotations

import numpy as np

from blisk_cam.core.runtime import parallel
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.verify import sweep
from blisk_cam.core.verify.forest import SweptForest
from blisk_cam.core.verify.sweep import SweptCutter, _first_of_equal_rows


def _first_by_dict(P, w):
    """The reference: a dict of each (member, coordinate bits)'s first row."""
    seen, out = {}, []
    for i, (p, m) in enumerate(zip(P, w, strict=True)):
        out.append(seen.setdefault((int(m), np.asarray(p, np.float64).tobytes()), i))
    return np.array(out)


def test_first_of_equal_rows_matches_bits_only():
    rng = np.random.default_rng(5)
    P = rng.normal(size=(400, 3))
    w = rng.integers(0, 3, 400)
    rep = rng.integers(0, 400, 300)  # repeats of earlier and later rows, some of others'
    P = np.vstack([P, P[rep], [[0.0, 1.0, 2.0], [-0.0, 1.0, 2.0], [np.nan, 1.0, 2.0],
                               [np.nan, 1.0, 2.0]]])
    w = np.concatenate([w, np.where(rng.random(300) < 0.8, w[rep], (w[rep] + 1) % 3),
                        [0, 0, 1, 1]])
    first = _first_of_equal_rows(P, w)
    np.testing.assert_array_equal(first, _first_by_dict(P, w))
    assert first[-3] == len(P) - 4 + 1 and first[-4] == len(P) - 4  # 0.0 and −0.0 apart
    assert first[-1] == len(P) - 2  # the same NaN bits: one search
    assert np.sum(first != np.arange(len(P))) > 200  # the repeats were found



def test_first_of_equal_rows_on_two_threads_matches_bits_only():
    """Enough rows to be split by the hash's top bit and matched on two threads: the same
    first rows as the reference (and as one thread)."""
    rng = np.random.default_rng(7)
    n = sweep._SPLIT_ROWS // 2 + 1000
    P = np.round(rng.normal(size=(n, 3)), 3)  # rounded: some rows equal by chance too
    w = rng.integers(0, 40, n)
    rep = rng.integers(0, n, n)
    P = np.vstack([P, P[rep]])
    w = np.concatenate([w, np.where(rng.random(n) < 0.8, w[rep], (w[rep] + 1) % 40)])
    assert len(P) > sweep._SPLIT_ROWS
    with parallel(2):
        first = _first_of_equal_rows(P, w)
    np.testing.assert_array_equal(first, _first_by_dict(P, w))
    with parallel(1):
        np.testing.assert_array_equal(_first_of_equal_rows(P, w), first)
    assert np.sum(first != np.arange(len(P))) > n // 2  # the repeats were found


def _moves(seed=4):
    """Bull-nose poses on three leaning helical passes, and points around them."""
    rng = np.random.default_rng(seed)
    tips, axes = [], []
    for i in range(3):
        t = np.linspace(0.0, 1.5, 60)
        tips.append(np.stack([40 * np.cos(t), 40 * np.sin(t), 3.0 * i + 0.3 * np.sin(3 * t)],
                             1))
        ax = np.stack([np.cos(t), np.sin(t), 0.3 + 0.2 * np.sin(2 * t + i)], 1)
        axes.append(ax / np.linalg.norm(ax, axis=1)[:, None])
    ta, tb = np.vstack([x[:-1] for x in tips]), np.vstack([x[1:] for x in tips])
    aa, ab = np.vstack([x[:-1] for x in axes]), np.vstack([x[1:] for x in axes])
    own = np.repeat(np.arange(3), 59)
    k = rng.integers(0, len(ta), 300)
    P = ta[k] + rng.normal(scale=4.0, size=(300, 3)) - 2.0 * aa[k]
    return ta, aa, tb, ab, own, P


def test_swept_cutter_and_forest_repeats_have_their_own_figures():
    ta, aa, tb, ab, own, P = _moves()
    cut = Cutter.bull(6.0, 2.0)
    rng = np.random.default_rng(6)
    idx = np.concatenate([np.arange(len(P)), rng.integers(0, len(P), 200)])
    idx = idx[rng.permutation(len(idx))]
    # a cutter: every row (repeats included) as its point asked alone
    d1, s1 = SweptCutter(cut, ta, aa, tb, ab, own).nearest(P)
    d, s = SweptCutter(cut, ta, aa, tb, ab, own).nearest(P[idx])
    np.testing.assert_array_equal(d, d1[idx])
    np.testing.assert_array_equal(s, s1[idx])
    assert (d1 < 0).any() and (d1 > 0).any()

    # a forest: a point repeated with another member is its own query
    def members():
        return [SweptCutter(cut, ta[own == g], aa[own == g], tb[own == g], ab[own == g],
                            own[own == g]) for g in range(3)]

    which = rng.integers(0, 3, len(P))
    w2 = np.where(rng.random(len(idx)) < 0.5, which[idx], (which[idx] + 1) % 3)
    df, sf = SweptForest(members()).nearest(P[idx], w2)
    ms = members()
    for g in range(3):
        sel = w2 == g
        dg, sg = ms[g].nearest(P[idx][sel])
        np.testing.assert_array_equal(df[sel], dg)
        np.testing.assert_array_equal(sf[sel], sg)
    d_lone, _ = SweptForest(members()).nearest(P[idx][:1], w2[:1])
    assert d_lone[0] == df[0]
