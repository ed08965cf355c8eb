"""The compiled chaining of a level curve's directed links (issue 21) against the numpy
reference on the same inputs (the same chains in the same order) and against what they
must mean.

Tests comparing the two backends skip (saying why) when the extension is not built."""

from __future__ import annotations

import numpy as np

from blisk_cam.core.geometry.mesh import _chain_directed
from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import mesh_tables as compiled_tables
from tests.support.kernels import needs_compiled

compiled = needs_compiled("chain_directed")


@compiled
def test_chains_equal_numpys_and_follow_the_links():
    rng = np.random.default_rng(11)
    for _ in range(20):
        n = int(rng.integers(5, 400))
        nodes = rng.permutation(n)
        links, i = [], 0
        while i < n - 1:  # paths and cycles of random lengths over shuffled nodes
            k = int(rng.integers(2, 12))
            c = nodes[i:i + k]
            i += k
            links += list(zip(c[:-1], c[1:], strict=True))
            if len(c) > 2 and rng.random() < 0.5:
                links.append((c[-1], c[0]))
        links = np.array(links, dtype=np.int64).reshape(-1, 2)
        links = links[rng.permutation(len(links))]
        got = _chain_directed(n, links)
        with backend.numpy_only():
            ref = _chain_directed(n, links)
        assert len(got) == len(ref)
        for (g, gc), (r, rc) in zip(got, ref, strict=True):
            assert gc == rc and g.dtype == r.dtype and np.array_equal(g, r)
        succ = dict(map(tuple, links))
        for chain, closed in got:
            assert all(succ[a] == b for a, b in zip(chain[:-1], chain[1:], strict=True))
            assert (succ.get(chain[-1]) == chain[0]) == closed
        assert sum(len(c) for c, _ in got) == len(np.unique(links))
    # not of the directed form (a node with two links out, a 2-cycle): both say so
    for bad in ([[0, 1], [0, 2]], [[0, 1], [1, 0]], [[3, 3]]):
        assert compiled_tables.chain_directed(4, np.array(bad)) is None
        with backend.numpy_only():
            assert _chain_directed(4, np.array(bad, dtype=np.int64)) is None
