"""The Jacobian window of the chunk loop (`railnav.navigation.loop.ChunkLoop.chunks`):
each chunk's ``u_lin`` is computed in batches of `LIN_BATCH_SAMPLES` rows and, across a
stream's blocks, from the samples kept of the earlier block and those of the next
(`following`). Reference: `ekf.step.window_median` of the whole series in one call (the
windows the module promises), to the bit, for one block and for blocks cut anywhere
(jittered times, a gap longer than the window, a block that starts or ends at it, a
block of one sample first, batches smaller than a chunk). Not covered, because not
promised: a block shorter than the window between two others (the rows before it see one
block ahead only)."""
from __future__ import annotations

import numpy as np
import pytest

import railnav.navigation.loop as loop_module
from ekf.step import window_median
from railnav.config import NavigatorConfig
from railnav.filters.protocol import make_filter
from railnav.navigation.loop import ChunkLoop
from railnav.simulation.scenarios import TRACKS_DIR
from trackmodel.io import read_track

DT = 0.01   # s, 100 Hz


@pytest.fixture(scope="module")
def filt():
    return make_filter(read_track(TRACKS_DIR / "curvy.csv"), NavigatorConfig(), None)


def _series(rng, n=3000):
    t = np.cumsum(rng.uniform(0.8 * DT, 1.2 * DT, n))
    t[1700:] += 0.9                                   # a gap of ~0.9 s (window 0.5 s)
    u = rng.normal(size=(n, 6))
    u[:, 2] += 9.81
    return t, u


def _u_lin(filt, blocks, epochs):
    """The u_lin of every chunk of `blocks` (each block's epoch samples `epochs[k]`), with
    each block's successor given as `following`."""
    loop = ChunkLoop(filt, NavigatorConfig(), sample_interval_s=DT)
    out = []
    for k, (t, u) in enumerate(blocks):
        following = blocks[k + 1] if k + 1 < len(blocks) else None
        out += [c.u_lin for c in loop.chunks(t, u, epochs[k], following=following)]
    return np.concatenate(out)


@pytest.mark.parametrize("cuts, batch", [((), 4096), ((1, 977, 1703, 2500), 4096),
                                         ((400, 1699), 37), ((1700,), 4096)])
def test_chunk_windows_are_the_whole_series_windows(filt, rng, monkeypatch, cuts, batch):
    monkeypatch.setattr(loop_module, "LIN_BATCH_SAMPLES", batch)
    t, u = _series(rng)
    window = loop_module.JACOBIAN_WINDOW_S
    edges = [0, *cuts, t.size]
    blocks = [(t[a:b], u[a:b]) for a, b in zip(edges[:-1], edges[1:])]
    every = np.arange(0, t.size, 97)                   # epoch samples: chunks of <= 97
    epochs = [every[(every >= a) & (every < b)] - a for a, b in zip(edges[:-1], edges[1:])]
    got = _u_lin(filt, blocks, epochs)
    assert np.array_equal(got, window_median(t, u, window))
