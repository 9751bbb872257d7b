r"""The hypotheses of the network navigator and what happens to them between cycles.

A `Hypothesis` is "the train is on netelement ``element``, in ``orientation``, with the
along-track state ``x`` (covariance ``P``)": one track-constrained filter of the run's
kind on that element's oriented track (`railnav.navigation.net_tracks`), with a log
weight. After each cycle of the lockstep (`railnav.navigation.network_navigator`):

* **Branching** (`branch`): a hypothesis whose ``s`` has left its element (past its end,
  or before its start when the train backs) is replaced by one child per navigable
  passage there, the state carried across the joint (`carried_state`: ``s`` continued along
  the route, everything else as it is), the weight split evenly among the children (the
  prior of a switch's ways:
  equal, the evidence decides). A hypothesis at a buffer stop has no passage: it runs on
  (its filter extrapolates the track) until its `railnav.navigation.loop.TrackEndWatch`
  (``Hypothesis.end_watch``, the single-track runs' rule) says the vehicle has left the
  track, and then dies: one that turns round a few metres past the stop lives on.
  A child at a joint starts a watch of its own (its parent's had no run going: it was
  not beyond an end that has a passage).
* **Merging** (`merge_coinciding`, GPB1, the seed's "pulsating" filter): hypotheses on one
  element and orientation whose ``(s, v)`` differ by less than
  `NetworkNavConfig.merge_mahalanobis` in the metric of their summed covariances are one
  Gaussian, moment-matched (`ekf.bank.merge_gaussians`); the heavier one's filter and
  history are kept. Two routes that join, and components of a Gaussian sum along ``s``
  that the data brought together, merge so.
* **Pruning** (`prune`): hypotheses whose probability falls below
  `NetworkNavConfig.prune_probability` are dropped, then the lightest beyond
  `NetworkNavConfig.max_hypotheses`. The probability thrown away is recorded per cycle
  (`NetworkResult.pruned_probability`): it bounds what the limits cost. A dropped
  hypothesis never comes back (the static bank's flaw, a weight floored at
  ``log(tiny)`` and revived by one cycle, cannot occur: weights are kept in log space,
  `ekf.bank.log_predict`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from itertools import count

import numpy as np
import numpy.typing as npt
from ekf.bank import logsumexp, merge_gaussians
from railnav.navigation.fix_bias import merged
from railnav.navigation.loop import TrackEndWatch
from railnav.navigation.net_tracks import OrientedTracks, bare
from railnav.navigation.network_config import NetworkNavConfig

__all__ = ["Hypothesis", "hypothesis", "branch", "branch_ahead",
           "rebased", "tail_pieces", "merge_coinciding", "prune", "carried_state",
           "normalized_weights", "most_probable", "evidence_share", "LEAD_MARGIN_M",
           "CYCLE_REACH_S"]

Array = npt.NDArray[np.float64]

#: Stretch beyond 3σ_s that a child's track takes in before and after the joint ahead, m.
LEAD_MARGIN_M = 20.0
#: A joint is taken in once it is within this much travel time (plus the lead), s (a
#: cycle is at most `railnav.navigation.loop.MAX_CHUNK_S`).
CYCLE_REACH_S = 1.0

_IDS = count()


@dataclass(eq=False)
class Hypothesis:
    """One hypothesis (module docstring).

    Attributes
    ----------
    pieces : tuple of (str, int, float)
        Its track (`railnav.navigation.net_tracks`): ``(element, orientation, start_m)``
        of each oriented netelement stretch, chained.
    ends : tuple of float
        ``s`` of each piece's end along that track, m.
    x : ndarray, shape (n,)
        Filter state on that track (posterior after the latest cycle).
    P : ndarray, shape (n, n)
    log_weight : float
        Unnormalized log probability.
    filt : railnav.filters.protocol.Filter
        The hypothesis's own filter object (rows, fault screen with its channel memory).
    path : tuple of railnav.navigation.route_path.PathEntry
        Every element it went through, the current last (inherited from its ancestors;
        `railnav.navigation.route_path.entered`).
    id, parent : int
        Unique id, and the id it branched from (-1: a start).
    fix_bias : railnav.navigation.fix_bias.FixBias or None
        Its estimate of the fixes' bias (`NetworkNavConfig.fix_bias_sigma_m`).
    end_watch : railnav.navigation.loop.TrackEndWatch
        Whether its vehicle has left its track at a buffer stop (module docstring); a
        rebased hypothesis keeps it (shifted with ``s``), a merged one the heavier's.
    """

    pieces: tuple
    ends: tuple
    x: Array
    P: Array
    log_weight: float
    filt: object
    path: tuple = ()
    parent: int = -1
    id: int = field(default_factory=lambda: next(_IDS))
    fix_bias: object = None
    end_watch: TrackEndWatch = field(default_factory=TrackEndWatch)

    def index(self, name: str) -> int:
        """Position of state `name` in the filter's layout."""
        return self.filt.layout.index(name)

    @property
    def s_m(self) -> float:
        """``s`` on its track, m."""
        return float(self.x[self._i_s])

    @cached_property
    def _i_s(self) -> int:
        """``index("s")``, looked up once (the filter is the hypothesis's for its life)."""
        return self.filt.layout.index("s")

    @property
    def length_m(self) -> float:
        """Length of its track, m."""
        return float(self.ends[-1])

    def where(self) -> tuple[str, int, float]:
        """The element and orientation the hypothesis is on, and its ``s`` on that
        oriented element (`railnav.navigation.net_tracks.OrientedTracks.locate`)."""
        s = self.s_m
        if len(self.pieces) == 1:
            element, orientation, start = self.pieces[0]
            return element, orientation, start + s
        j = int(min(np.searchsorted(self.ends, s), len(self.pieces) - 1))
        element, orientation, start = self.pieces[j]
        return element, orientation, start + s - (self.ends[j - 1] if j else 0.0)

    @property
    def element(self) -> str:
        return self.where()[0]

    @property
    def orientation(self) -> int:
        return self.where()[1]


def hypothesis(tracks: OrientedTracks, pieces, x: Array, P: Array, log_weight: float, filt,
               path: tuple = (), parent: int = -1, *, fix_bias=None,
               end_watch: TrackEndWatch | None = None) -> Hypothesis:
    """A `Hypothesis` on `pieces` (its piece ends from the network; a new end watch
    unless given)."""
    pieces = tuple((e, int(o), float(st)) for e, o, st in pieces)
    return Hypothesis(pieces, tuple(float(v) for v in tracks.piece_ends(pieces)),
                      np.asarray(x, dtype=float), np.asarray(P, dtype=float),
                      float(log_weight), filt, tuple(path), parent, fix_bias=fix_bias,
                      end_watch=end_watch or TrackEndWatch())


def evidence_share(nav: NetworkNavConfig, since_epoch_s: float) -> float:
    """What one epoch's evidence counts (`NetworkNavConfig.evidence_correlation_s`)."""
    if nav.evidence_correlation_s <= 0.0:
        return 1.0
    rho = math.exp(-max(since_epoch_s, 0.0) / nav.evidence_correlation_s)
    return (1.0 - rho) / (1.0 + rho)


def normalized_weights(hyps) -> Array:
    """Probabilities of the hypotheses (their weights normalized), shape (K,)."""
    if len(hyps) < 2:
        return np.ones(len(hyps))
    log_w = np.array([h.log_weight for h in hyps], dtype=float)
    return np.exp(log_w - logsumexp(log_w))


def most_probable(hyps) -> int:
    """Index of the hypothesis of the largest weight (the first of equals)."""
    return int(np.argmax([h.log_weight for h in hyps])) if len(hyps) > 1 else 0


def carried_state(filt, x: Array, s_new: float) -> Array:
    """``x`` carried across a joint: ``s = s_new`` on the track entered, every other state
    as it is (the attitude states are the body's, absolute: the vehicle does not turn
    because the map's tangent kinks at a joint; what a kink costs the inertial filters is
    `railnav.navigation.hypothesis_step`'s business)."""
    out = np.array(x, dtype=float)
    out[filt.layout.index("s")] = s_new
    return out


def branch(hyp: Hypothesis, tracks: OrientedTracks, make_child, time_s: float
           ) -> list[Hypothesis] | None:
    """The children of a hypothesis that has left its track (module docstring), or None
    while it has not (or at a buffer stop).

    Parameters
    ----------
    hyp : Hypothesis
    tracks : OrientedTracks
    make_child : callable(parent, pieces) -> filter object
        The child's filter on the pieces' track (its fault screen's channel memory carried
        from the parent's).
    time_s : float
        Time of the crossing (the cycle's end), s.
    """
    passages = tracks.leaving(hyp.pieces, hyp.s_m)
    if not passages:
        return None
    log_share = -math.log(len(passages))
    children = []
    for p in passages:
        pieces = bare(p.element, p.orientation)
        filt = make_child(hyp, pieces)
        children.append(hypothesis(tracks, pieces, carried_state(filt, hyp.x, p.s_m),
                                   hyp.P.copy(), hyp.log_weight + log_share, filt,
                                   hyp.path, hyp.id, fix_bias=hyp.fix_bias))
    return children


def tail_pieces(hyp: Hypothesis, s0: float) -> tuple:
    """The pieces of `hyp`'s track from ``s0`` on (the first one cut there)."""
    j = int(min(np.searchsorted(hyp.ends, s0, side="right"), len(hyp.pieces) - 1))
    element, orientation, start = hyp.pieces[j]
    into = s0 - (hyp.ends[j - 1] if j else 0.0)
    return ((element, orientation, start + into),) + hyp.pieces[j + 1:]


def _lead_m(hyp: Hypothesis) -> float:
    """How far ahead (and behind) a joint is taken into a child's track: 3σ_s plus
    `LEAD_MARGIN_M` plus a cycle's travel."""
    i_s, i_v = hyp.index("s"), hyp.index("v")
    return 3.0 * math.sqrt(max(hyp.P[i_s, i_s], 0.0)) + LEAD_MARGIN_M + \
        abs(float(hyp.x[i_v])) * CYCLE_REACH_S


def branch_ahead(hyp: Hypothesis, tracks: OrientedTracks, make_child
                 ) -> list[Hypothesis] | None:
    """Children that chain the joint ahead into their tracks (module docstring), for a
    hypothesis travelling forwards within `_lead_m` of the end of its track; None when it
    is not (or at a buffer stop)."""
    s, lead = hyp.s_m, _lead_m(hyp)
    if float(hyp.x[hyp.index("v")]) <= 0.0 or hyp.length_m - s > lead:
        return None
    element, orientation, _ = hyp.pieces[-1]
    ways = tracks.network.successors(element, orientation)
    if not ways:
        return None
    s0 = max(0.0, s - lead)
    head = tail_pieces(hyp, s0)
    log_share = -math.log(len(ways))
    children = []
    for e, o in ways:
        pieces = head + bare(e, o)
        filt = make_child(hyp, pieces)
        children.append(hypothesis(tracks, pieces, carried_state(filt, hyp.x, s - s0),
                                   hyp.P.copy(), hyp.log_weight + log_share, filt,
                                   hyp.path, hyp.id, fix_bias=hyp.fix_bias))
    return children


def rebased(hyp: Hypothesis, tracks: OrientedTracks, make_child) -> Hypothesis:
    """`hyp` without the pieces its vehicle left more than `_lead_m` behind (a new filter
    on the shorter track, ``s`` shifted; the same hypothesis otherwise)."""
    if len(hyp.pieces) < 2 or hyp.s_m - hyp.ends[0] < _lead_m(hyp):
        return hyp
    pieces = hyp.pieces[1:]
    filt = make_child(hyp, pieces)
    out = hypothesis(tracks, pieces, carried_state(filt, hyp.x, hyp.s_m - hyp.ends[0]),
                     hyp.P, hyp.log_weight, filt, hyp.path, hyp.parent,
                     fix_bias=hyp.fix_bias, end_watch=hyp.end_watch.shifted(-hyp.ends[0]))
    out.id = hyp.id
    return rebased(out, tracks, make_child)


def _sv_block(hyp: Hypothesis) -> tuple[Array, Array]:
    idx = [hyp.index("s"), hyp.index("v")]
    return hyp.x[idx], hyp.P[np.ix_(idx, idx)]


def _coincide(a: Hypothesis, b: Hypothesis, threshold: float) -> bool:
    xa, Pa = _sv_block(a)
    xb, Pb = _sv_block(b)
    d = xa - xb
    return float(d @ np.linalg.solve(Pa + Pb, d)) < threshold ** 2


def merge_coinciding(hyps: list[Hypothesis], threshold: float) -> tuple[list[Hypothesis], int]:
    """Hypotheses with coinciding states merged (module docstring); the merged list and
    how many merges were made."""
    if threshold <= 0.0 or len(hyps) < 2:
        return hyps, 0
    order = sorted(hyps, key=lambda h: -h.log_weight)
    groups: list[list[Hypothesis]] = []
    for h in order:
        for g in groups:
            head = g[0]
            if head.pieces == h.pieces and head.x.shape == h.x.shape and \
                    _coincide(head, h, threshold):
                g.append(h)
                break
        else:
            groups.append([h])
    out, merges = [], 0
    for g in groups:
        if len(g) > 1:
            log_w = np.array([h.log_weight for h in g])
            total = float(logsumexp(log_w))
            x, P = merge_gaussians(np.exp(log_w - total), np.array([h.x for h in g]),
                                   np.array([h.P for h in g]))
            g[0].x, g[0].P, g[0].log_weight = x, P, total
            g[0].fix_bias = merged(np.exp(log_w - total), [h.fix_bias for h in g])
            merges += len(g) - 1
        out.append(g[0])
    return out, merges


def prune(hyps: list[Hypothesis], config: NetworkNavConfig) -> tuple[list[Hypothesis], float]:
    """Hypotheses below the probability limit dropped, then the lightest beyond the count
    limit; the kept ones (heaviest first) and the probability dropped."""
    if len(hyps) < 2:
        return hyps, 0.0
    w = normalized_weights(hyps)
    order = np.argsort(-w, kind="stable")
    keep = [int(k) for k in order if w[k] >= config.prune_probability]
    keep = keep[:config.max_hypotheses] or [int(order[0])]
    return [hyps[k] for k in keep], float(1.0 - w[keep].sum())
