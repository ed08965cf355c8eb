"""The batched forward step (sampling.forward_step_indices) keeps exactly the samples of the
one-test-at-a-time search it replaced, and those samples hold the chord tolerance."""

import numpy as np
import pytest

from blisk_cam.core.paths.sampling import _span_deviations, forward_step_indices


def _max_dev_reference(X, i, j):
    """The deviation as the sequential search computed it (einsum, one span at a time)."""
    if j - i < 2:
        return np.zeros(X.shape[1])
    a = X[i]
    q = X[i + 1 : j] - a
    ab = X[j] - a
    L2 = np.einsum("pj,pj->p", ab, ab)
    t = np.clip(np.einsum("wpj,pj->wp", q, ab) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
    d = q - t[:, :, None] * ab
    return np.sqrt(np.einsum("wpj,wpj->wp", d, d).max(axis=0))


def _sequential_reference(P, C, chord, centre_chord, max_step=None):
    """The greedy search one test at a time: exponential search from the last step, then
    bisection (the algorithm before the batches)."""
    X = np.stack([P, C], axis=1)
    last = len(X) - 1

    def ok(i, j):
        if max_step is not None and np.linalg.norm(X[j, 0] - X[i, 0]) > max_step:
            return False
        dev = _max_dev_reference(X, i, j)
        return bool(dev[0] <= chord) and bool(dev[1] <= centre_chord)

    keep, i, prev = [0], 0, 2
    while i < last:
        good, step, bad = i + 1, max(prev, 2), None
        while True:
            j = i + step
            if j >= last:
                if ok(i, last):
                    good = last
                else:
                    bad = last
                break
            if ok(i, j):
                good, step = j, step * 2
            else:
                bad = j
                break
        if bad is not None:
            lo, hi = good, bad
            while hi - lo > 1:
                mid = (lo + hi) // 2
                lo, hi = (mid, hi) if ok(i, mid) else (lo, mid)
            good = lo
        keep.append(good)
        prev = good - i
        i = good
    return np.asarray(keep)


def _segment_distance(points, a, b):
    """Brute force: distance of each point to the segment a→b (its own formula)."""
    ab = b - a
    L2 = ab @ ab
    t = np.zeros(len(points)) if L2 == 0 else np.clip((points - a) @ ab / L2, 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


def _curves():
    """Assorted test polylines (P, C): smooth, noisy (the tolerance test is then far from
    monotone along the polyline), with repeated points, a closed loop's repeated first point,
    long straight runs and a sharp edge."""
    rng = np.random.default_rng(3)
    out = []
    for n, noise in ((400, 0.0), (600, 0.003), (300, 0.02)):
        t = np.linspace(0.0, 5.0, n)
        P = np.stack([20 * np.cos(t), 15 * np.sin(t), 0.5 * t], axis=1)
        P += rng.normal(scale=noise, size=P.shape)
        N = np.stack([np.cos(3 * t), np.sin(3 * t), np.ones_like(t)], axis=1)
        C = P + 6.0 * N / np.linalg.norm(N, axis=1)[:, None]
        out.append((P, C))
    P, C = out[0]
    out.append((np.repeat(P, 2, axis=0), np.repeat(C, 2, axis=0)))  # zero-length chords
    out.append((np.vstack([P, P[:1]]), np.vstack([C, C[:1]])))  # closed: back to the start
    line = np.outer(np.linspace(0, 100, 500), [1.0, 0.2, 0.0])
    kink = np.vstack([line, line[-1] + np.outer(np.linspace(0, 30, 200)[1:], [0, 1.0, 0])])
    out.append((kink, kink + [0, 0, 6.0]))  # straight runs: steps of hundreds of points
    out.append((P[:2], C[:2]))
    out.append((P[:3], C[:3]))
    return out


@pytest.mark.parametrize("chord", [0.002, 0.01, 0.05])
def test_batched_search_keeps_the_samples_of_the_sequential_search(chord):
    for P, C in _curves():
        for max_step in (None, 3.0):
            got = forward_step_indices(P, C, chord, max_step=max_step, centre_chord=0.6 * chord)
            ref = _sequential_reference(P, C, chord, 0.6 * chord, max_step)
            assert np.array_equal(got, ref)


def test_every_kept_span_holds_the_tolerance_and_one_more_point_breaks_it():
    """Measured independently of the search: every skipped point within the tolerance of
    its move (CC and centre), and the move to the point after each kept one not."""
    chord, cchord = 0.01, 0.006
    for P, C in _curves()[:3]:
        keep = forward_step_indices(P, C, chord, centre_chord=cchord)
        assert keep[0] == 0 and keep[-1] == len(P) - 1 and np.all(np.diff(keep) > 0)
        for i, g in zip(keep[:-1], keep[1:], strict=True):
            within = 1 + 1e-12
            assert _segment_distance(P[i + 1 : g], P[i], P[g]).max(initial=0) <= chord * within
            assert _segment_distance(C[i + 1 : g], C[i], C[g]).max(initial=0) <= cchord * within
            if g < len(P) - 1:
                beyond = (_segment_distance(P[i + 1 : g + 1], P[i], P[g + 1]).max() > chord
                          or _segment_distance(C[i + 1 : g + 1], C[i], C[g + 1]).max() > cchord)
                assert beyond


def test_span_deviations_are_the_einsum_deviations_to_the_last_bit():
    rng = np.random.default_rng(11)
    P, C = _curves()[1]
    X = np.stack([P, C], axis=1)
    XT = np.ascontiguousarray(X.transpose(2, 1, 0))
    cols = np.arange(len(P) + 1)
    for _ in range(300):
        i = int(rng.integers(0, len(P) - 2))
        js = np.unique(rng.integers(i + 1, min(len(P), i + 120), int(rng.integers(1, 25))))
        got = _span_deviations(XT, i, js, cols)
        ref = np.array([_max_dev_reference(X, i, int(j)) for j in js])
        assert np.array_equal(got, ref)
