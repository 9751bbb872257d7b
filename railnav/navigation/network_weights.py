r"""The weights of the network navigator's hypotheses: evidence, Markov prior, mixing.

After each cycle:

1. **Evidence on a common basis.** The epoch's GNSS rows and fix rows are scored for
   every hypothesis over one set of rows, those that some hypothesis's fault screen used
   (`railnav.navigation.bank.common_log_likelihoods`, the track bank's rule carried over:
   a row that the hypothesis on the wrong track rejects because the wrong geometry biases
   it is evidence against that track; a row every filter refuses is no evidence). The
   continuous measurement (the inertial filters' accelerometer pseudo-observation) is the
   same for all hypotheses; its innovations are scored on one covariance per step
   (`railnav.navigation.hypothesis_step.common_continuous_log_likelihoods`,
   `NetworkNavConfig.continuous_evidence`): a branch's curvature, or a wrong ``s`` in a
   curvy stretch, shows there first.
2. **Markov prior for leaving the track model.** A train may be on a track abreast of the
   one a hypothesis says (a crossover the map lacks, a map error): each hypothesis gives
   its probability to the hypotheses *abreast* of it at the rate ε, alike (`abreast`:
   positions within `NetworkNavConfig.crossing_radius_m`, travelling the same way, on
   another element; `crossing_matrix`, the exact chain): ``μ_j ∝ L_j Σ_i Π_ij μ_i``
   computed in log space (`ekf.bank.log_predict`, no floor under a weight). Hypotheses
   with nothing abreast keep their probability (a switch's branches that have parted,
   Gaussian-sum components along one element).
3. **IMM restarts** (`mix_states`): each hypothesis restarts from the mixture of the
   abreast estimates brought onto its own track (`railnav.navigation.bank.convert_state`),
   weighted ``μ_{i|j} = Π_ij μ_i / c_j`` (`ekf.bank.imm_starts`), so that the filter on an
   unlikely parallel track follows the likely one instead of drifting on its own wrong
   geometry, ready if the train does cross.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from ekf.bank import imm_mixing, imm_starts, log_predict, uniform_switching
from railnav.errors import RailnavError
from railnav.navigation.bank import common_log_likelihoods, evidence_rows, moved_state
from railnav.navigation.hypothesis_step import common_continuous_log_likelihoods
from trackmodel.earth import C_n_e
from trackmodel.network_points import points_on

__all__ = ["cycle_evidence", "hypothesis_points", "ecef_points", "track_points_of",
           "cycle_points", "abreast", "crossing_matrix", "reweight", "mix_states",
           "converted", "converted_pairs", "forget_offsets"]

Array = npt.NDArray[np.float64]


def cycle_evidence(outcome, count: int, *, continuous: bool, share: float = 1.0
                   ) -> tuple[Array, int]:
    """Each hypothesis's log-likelihood of the cycle (module docstring, 1) and the number
    of rows the evidence used.

    Parameters
    ----------
    outcome : railnav.navigation.hypothesis_step.CycleOutcome
    count : int
        Hypotheses stepped.
    continuous : bool
        Add the continuous measurement's evidence.
    share : float
        What the epoch's evidence counts (`railnav.navigation.hypotheses.evidence_share`).
    """
    log_lik = np.zeros(count)
    if continuous and outcome.innov_c is not None:
        log_lik = common_continuous_log_likelihoods(outcome.innov_c, outcome.S_c)
    rows = 0
    if outcome.evidence is not None:
        log_lik, rows = log_lik + share * outcome.evidence, outcome.evidence_rows
    elif outcome.screens:
        log_lik = log_lik + share * common_log_likelihoods(outcome.screens)
        rows = len(evidence_rows(outcome.screens))
    if outcome.evidence_whole is not None:
        log_lik = log_lik + outcome.evidence_whole
    return log_lik, rows


def hypothesis_points(hyps, tracks, outcome=None, *, track_points: list | None = None
                      ) -> tuple[Array, Array]:
    """ECEF position (m) and ECEF unit tangent of the oriented track at each hypothesis's
    ``s`` (clamped to its track), shapes (K, 3) (zeros for a single hypothesis); those of
    the cycle's `outcome` when its stepper gave them. `track_points`: the hypotheses'
    `track_points_of` when known."""
    if len(hyps) < 2:                       # nothing to be abreast of
        return np.zeros((len(hyps), 3)), np.zeros((len(hyps), 3))
    if outcome is not None and outcome.points is not None:
        return outcome.points
    return ecef_points(track_points_of(hyps) if track_points is None else track_points)


def ecef_points(points) -> tuple[Array, Array]:
    """ECEF position (m) and ECEF unit tangent of track points (`track_points_of`'s),
    shapes (K, 3), all rotated in one evaluation."""
    if not points:
        return np.zeros((0, 3)), np.zeros((0, 3))
    lat = np.array([float(p.lat) for p in points])
    lon = np.array([float(p.lon) for p in points])
    r = np.array([np.asarray(p.r_e, dtype=float).reshape(3) for p in points])
    u_n = np.array([np.asarray(p.u_n, dtype=float).reshape(3) for p in points])
    return r, np.einsum("kij,kj->ki", np.asarray(C_n_e(lat, lon)).reshape(-1, 3, 3), u_n)


def track_points_of(hyps) -> list:
    """The track point (`trackmodel.network_points.points_on`) of each hypothesis at its
    ``s`` clamped to its track: what `hypothesis_points` and the conversions of
    `mix_states` start from, evaluated once for both."""
    tracks = [h.filt.track for h in hyps]
    return points_on(tracks, [min(max(h.s_m, 0.0), t.length_m) for h, t in zip(hyps, tracks)])


def cycle_points(hyps) -> tuple[list, dict]:
    """`track_points_of` the hypotheses and, in the same evaluation, the first Newton
    points that `converted_pairs` wants for the pairs `mix_states` may convert: for each
    ordered pair ``(i, j)`` whose pair of tracks has an offset (`_target_s`), the point of
    j's track at ``s_i`` plus that offset, clamped, as ``{(i, j): (s_g, point)}`` (the
    same numbers as evaluated there: `points_on` is pure per point)."""
    tracks = [h.filt.track for h in hyps]
    s = [min(max(h.s_m, 0.0), t.length_m) for h, t in zip(hyps, tracks)]
    pairs, s_g = [], []
    for i, a in enumerate(tracks):
        for j, b in enumerate(tracks):
            offset = _OFFSETS.get((id(a), id(b))) if i != j else None
            if offset is not None:
                pairs.append((i, j))
                s_g.append(min(max(s[i] + offset, 0.0), b.length_m))
    both = points_on(tracks + [tracks[j] for _, j in pairs], s + s_g)
    return both[:len(hyps)], {p: (g, q) for p, g, q in zip(pairs, s_g, both[len(hyps):])}


def _signed_speed(filt) -> bool:
    """Whether a filter's travel direction is its speed's sign (no attitude states)."""
    return "yaw" not in filt.layout.names


def abreast(hyps, r_e: Array, tangent_e: Array, radius_m: float) -> list[list[int]]:
    """For each hypothesis, the others abreast of it (module docstring, 2): on another
    element or orientation, within `radius_m` (3-D distance of the track points), with
    tangents pointing the same way (either way for filters whose speed is signed)."""
    K = len(hyps)
    out: list[list[int]] = [[] for _ in range(K)]
    if K < 2:
        return out
    d = np.linalg.norm(r_e[:, None, :] - r_e[None, :, :], axis=2)
    same_way = (tangent_e @ tangent_e.T > 0.0) | _signed_speed(hyps[0].filt)
    codes: dict[tuple, int] = {}
    on = np.array([codes.setdefault(h.where()[:2], len(codes)) for h in hyps])
    # i != j follows from another element or orientation
    linked = (d <= radius_m) & same_way & (on[:, None] != on[None, :])
    return [np.flatnonzero(row).tolist() for row in linked]


def crossing_matrix(neighbours: list[list[int]], rate_per_s: float, dt_s: float) -> Array:
    """``Π[i, j]`` over ``dt_s`` of the chain that leaves hypothesis i at ``rate_per_s`` for
    its abreast hypotheses alike (generator ``Λ_ij = ε/|abreast(i)|``, ``Λ_ii = −ε``; none
    abreast: it keeps all): ``Π = exp(Λ Δt)`` per group of hypotheses linked by being
    abreast, in closed form (`ekf.bank.uniform_switching`) where every one of a group is
    abreast of all the others (a double line, parallel tracks), `scipy.linalg.expm` else.
    Rows sum to 1; the exact chain, so that the probabilities of hypotheses abreast
    relax in an outage as the chain does (two: ``μ − ½ ∝ e^{−2εt}``). Read-only (kept
    for the cycles that ask again)."""
    K = len(neighbours)
    if rate_per_s == 0.0 or dt_s <= 0.0:
        return np.eye(K)
    key = (tuple(tuple(nb) for nb in neighbours), float(rate_per_s), float(dt_s))
    Pi = _CROSSINGS.get(key)
    if Pi is None:
        Pi = _crossing_matrix(neighbours, rate_per_s, dt_s)
        Pi.flags.writeable = False
        if len(_CROSSINGS) >= MAX_CROSSINGS:
            _CROSSINGS.clear()
        _CROSSINGS[key] = Pi
    return Pi


#: Crossing matrices computed, by (abreast lists, rate, interval): cycles repeat them (the
#: same hypotheses abreast, the same interval), and `scipy.linalg.expm` costs ~10 ms.
_CROSSINGS: dict[tuple, Array] = {}
#: Matrices remembered at most (then forgotten together).
MAX_CROSSINGS = 1000


def _crossing_matrix(neighbours: list[list[int]], rate_per_s: float, dt_s: float) -> Array:
    """`crossing_matrix` computed."""
    K = len(neighbours)
    Pi = np.eye(K)
    for group in _linked_groups(neighbours):
        n = len(group)
        if all(len(neighbours[i]) == n - 1 for i in group):
            block = uniform_switching(n, rate_per_s, dt_s)
        else:
            where = {i: k for k, i in enumerate(group)}
            gen = np.zeros((n, n))
            for i in group:
                gen[where[i], [where[j] for j in neighbours[i]]] = rate_per_s / len(neighbours[i])
                gen[where[i], where[i]] = -rate_per_s
            block = sla.expm(gen * dt_s)
        Pi[np.ix_(group, group)] = block
    return Pi


def _linked_groups(neighbours: list[list[int]]) -> list[list[int]]:
    """The connected groups (>= 2 members, sorted) of the symmetric abreast relation."""
    seen, out = set(), []
    for i, nb in enumerate(neighbours):
        if not nb or i in seen:
            continue
        group, todo = [], [i]
        seen.add(i)
        while todo:
            k = todo.pop()
            group.append(k)
            for j in neighbours[k]:
                if j not in seen:
                    seen.add(j)
                    todo.append(j)
        out.append(sorted(group))
    return out


def reweight(hyps, log_lik: Array, transition: Array) -> None:
    """``log w_j ← log Σ_i Π_ij w_i + log L_j`` for every hypothesis, in place."""
    if len(hyps) == 1:                        # one hypothesis: its weight is all there is
        hyps[0].log_weight = 0.0
        return
    log_w = np.array([h.log_weight for h in hyps], dtype=float)
    log_w = log_predict(log_w, transition) + log_lik
    top = float(np.max(log_w)) if np.isfinite(log_w).any() else 0.0
    for h, lw in zip(hyps, log_w - top):                  # kept near 0: no overflow
        h.log_weight = float(lw)


def mix_states(hyps, mu: Array, transition: Array, min_weight: float, *,
               track_points: list | None = None, newton_points: dict | None = None) -> None:
    """IMM restarts of the hypotheses that have something abreast (module docstring, 3).

    The states of all pairs the mixing uses are converted first, together
    (`converted_pairs`: the track points of all pairs in two evaluations instead of two per
    pair; the same numbers). `track_points`: the hypotheses' `track_points_of`, when
    known (the sources' points are then not evaluated again); `newton_points`: the first
    Newton points of `cycle_points`, when known (used where they are at the ``s`` the
    conversion asks for)."""
    K = len(hyps)
    if K < 2 or np.allclose(transition, np.eye(K)):
        return
    _, uses = imm_mixing(mu, transition, min_weight)
    pairs = [(i, j) for j, use in enumerate(uses) if use != [j] for i in use if i != j]
    done = converted_pairs([hyps[i].filt for i, _ in pairs], [hyps[j].filt for _, j in pairs],
                           [hyps[i].x for i, _ in pairs], [hyps[i].P for i, _ in pairs],
                           source_points=None if track_points is None else
                           [track_points[i] for i, _ in pairs],
                           first_guesses=None if newton_points is None else
                           [newton_points.get(pair) for pair in pairs])
    table = dict(zip(pairs, done))

    def convert(i: int, j: int, x: Array, P: Array):
        return table[(i, j)]

    x0, P0 = imm_starts(mu, transition, [h.x for h in hyps], [h.P for h in hyps],
                        convert=convert, min_weight=min_weight)
    for h, x, P in zip(hyps, x0, P0):
        h.x, h.P = np.asarray(x, dtype=float), np.asarray(P, dtype=float)


#: Offsets ``s_target − s_source`` found for pairs of tracks, for the next conversion
#: (by the tracks' ``id``: forgotten at the start of each run, `forget_offsets`, so that a
#: run's numbers do not depend on the runs before it in the process, whose freed tracks'
#: ids new tracks may reuse).
_OFFSETS: dict[tuple[int, int], float] = {}
#: A Newton step longer than this (m) means the guess was poor: project instead.
NEWTON_MAX_STEP_M = 1.0
#: Pairs remembered at most (then forgotten together).
MAX_OFFSETS = 10_000


def forget_offsets() -> None:
    """Forget the offsets found so far (a run's start: `_OFFSETS`)."""
    _OFFSETS.clear()


def _target_s(sources, targets, p_src: list, s_src: list, first_points=None) -> list[float]:
    """``s`` of the point of each target's track nearest its source's point ``p_src`` at
    ``s_src``: one Newton step along the target's tangent from the offset last found for
    the pair of tracks (once the offset of the pair is known), else the projection.

    Pairs are taken in order; a pair of tracks met again within the batch starts from the
    offset its previous occurrence found (waves: the k-th occurrences together).
    `first_points`: a callable giving the first wave's Newton points on the targets (made
    with the sources' points in one evaluation, `converted_pairs`)."""
    keys = [(id(a.track), id(b.track)) for a, b in zip(sources, targets)]
    seen: dict[tuple[int, int], int] = {}
    waves: list[list[int]] = []
    for k, key in enumerate(keys):
        n = seen.get(key, 0)
        seen[key] = n + 1
        if n == len(waves):
            waves.append([])
        waves[n].append(k)
    out = [0.0] * len(keys)
    for wave in waves:
        if len(_OFFSETS) + len(wave) > MAX_OFFSETS:      # where the table is cleared: as
            for k in wave:                               # pair by pair
                out[k] = _one_target_s(sources[k], targets[k], p_src[k], s_src[k], keys[k])
            continue
        guessed = [k for k in wave if keys[k] in _OFFSETS]
        s_g = [min(max(s_src[k] + _OFFSETS[keys[k]], 0.0), targets[k].track.length_m)
               for k in guessed]
        points = first_points(guessed, s_g) if first_points is not None and wave is waves[0] \
            else points_on([targets[k].track for k in guessed], s_g)
        newton = dict(zip(guessed, _newton_many(points, [p_src[k] for k in guessed], s_g)))
        for k in wave:
            found = newton.get(k)
            if found is None:
                found = _projected(targets[k], p_src[k])
            _OFFSETS[keys[k]] = found - s_src[k]
            out[k] = found
    return out


def _newton(p_g, p_src, s_g: float) -> float | None:
    """``s`` one Newton step from ``s_g`` (its point `p_g`) towards the point nearest
    `p_src`; None when the step is longer than `NEWTON_MAX_STEP_M`."""
    tangent = C_n_e(float(p_g.lat), float(p_g.lon)) @ np.asarray(p_g.u_n, dtype=float)
    step = -float((np.asarray(p_g.r_e) - np.asarray(p_src.r_e)) @ tangent)
    return s_g + step if abs(step) <= NEWTON_MAX_STEP_M else None


def _newton_many(p_g: list, p_src: list, s_g: list) -> list[float | None]:
    """`_newton` of each ``(p_g[k], p_src[k], s_g[k])``, the rotations and products of all
    at once (`trackmodel.earth.C_n_e` elementwise; NumPy's stacked ``matmul`` makes each
    point's BLAS products as `_newton`'s: the same numbers)."""
    if not p_g:
        return []
    lat = np.array([float(p.lat) for p in p_g])
    lon = np.array([float(p.lon) for p in p_g])
    u_n = np.array([np.asarray(p.u_n, dtype=float) for p in p_g])
    d = np.array([np.asarray(a.r_e) for a in p_g]) - \
        np.array([np.asarray(b.r_e) for b in p_src])
    tangent = (np.asarray(C_n_e(lat, lon)).reshape(-1, 3, 3) @ u_n[..., None])
    step = -(d[:, None, :] @ tangent)[:, 0, 0]
    return [g + float(st) if abs(float(st)) <= NEWTON_MAX_STEP_M else None
            for g, st in zip(s_g, step)]


def _projected(target, p_src) -> float:
    """``s`` of the projection of `p_src` onto `target`'s track."""
    return float(target.track.project(p_src.lat, p_src.lon, p_src.h).s[0])


def _one_target_s(source, target, p_src, s_src: float, key) -> float:
    """`_target_s` of one pair, the offsets table cleared when it is full."""
    guess = _OFFSETS.get(key)
    if guess is not None:
        s_g = min(max(s_src + guess, 0.0), target.track.length_m)
        found = _newton(target.track.at(s_g), p_src, s_g)
        if found is not None:
            _OFFSETS[key] = found - s_src
            return found
    s_tgt = _projected(target, p_src)
    if len(_OFFSETS) > MAX_OFFSETS:
        _OFFSETS.clear()
    _OFFSETS[key] = s_tgt - s_src
    return s_tgt


def converted(source, target, x: Array, P: Array) -> tuple[Array, Array]:
    """`railnav.navigation.bank.convert_state` (``s`` by `_target_s`), and for filters
    whose speed is signed also between tracks that run opposite ways there: ``s`` from the
    projection, ``v`` (and its covariances) negated."""
    return converted_pairs([source], [target], [x], [P])[0]


def converted_pairs(sources, targets, xs, Ps, *, source_points: list | None = None,
                    first_guesses: list | None = None) -> list[tuple[Array, Array]]:
    """`converted` of each pair ``(sources[k], targets[k], xs[k], Ps[k])``, in order, the
    track points of all pairs evaluated together (`trackmodel.network_points.points_on`:
    the same numbers as `trackmodel.track.Track.at` point by point); `source_points`: the
    sources' points at their clamped ``s`` when known; `first_guesses`: for each pair,
    ``(s_g, point)`` of its target's track, or None (`cycle_points`), used as the first
    wave's Newton point where ``s_g`` is the one that wave asks for."""
    if not sources:
        return []
    s_raw = [float(x[f.layout.index("s")]) for x, f in zip(xs, sources)]
    s_src = [min(max(s, 0.0), f.track.length_m) for s, f in zip(s_raw, sources)]
    # the sources' points and the first Newton points need nothing from each other: together
    first = _first_wave(sources, targets, s_src)
    if source_points is None:
        both = points_on([f.track for f in sources] + [targets[k].track for k in first],
                         s_src + list(first.values()))
        p_src, newton_points = both[:len(sources)], both[len(sources):]
    else:
        p_src = list(source_points)
        known = {k: first_guesses[k][1] for k in first if first_guesses is not None
                 and first_guesses[k] is not None and first_guesses[k][0] == first[k]}
        order = list(first)
        newton_points = [known.get(k) for k in order]
        missing = [m for m, k in enumerate(order) if k not in known]
        for m, p in zip(missing, points_on([targets[order[m]].track for m in missing],
                                           [first[order[m]] for m in missing])):
            newton_points[m] = p
    newton = dict(zip(first, newton_points))

    def first_points(guessed, s_g):
        if all(k in newton for k in guessed):
            return [newton[k] for k in guessed]
        return points_on([targets[k].track for k in guessed], s_g)

    s_tgt = _target_s(sources, targets, p_src, s_src, first_points)
    # the targets' tangents and angles only (`_converted` reads no position of them)
    p_tgt = points_on([f.track for f in targets],
                      [min(max(s, 0.0), f.track.length_m) for s, f in zip(s_tgt, targets)],
                      positions=False)
    return [_converted(*args) for args in zip(sources, xs, Ps, s_raw, s_src, s_tgt, p_src,
                                              p_tgt)]


def _first_wave(sources, targets, s_src: list) -> dict[int, float]:
    """``s_g`` of the pairs of `_target_s`'s first wave that have an offset to start from,
    by pair index (what `_target_s` computes for them; the table is read, not changed)."""
    out, seen = {}, set()
    if len(_OFFSETS) + len(sources) > MAX_OFFSETS:
        return out
    for k, (a, b) in enumerate(zip(sources, targets)):
        key = (id(a.track), id(b.track))
        if key in seen:
            continue
        seen.add(key)
        if key in _OFFSETS:
            out[k] = min(max(s_src[k] + _OFFSETS[key], 0.0), b.track.length_m)
    return out


def _converted(source, x: Array, P: Array, s_raw: float, s_src: float, s_tgt: float,
               p_src, p_tgt) -> tuple[Array, Array]:
    """`converted` of one pair once the track points are known."""
    lay = source.layout
    if float(np.dot(p_src.u_n, p_tgt.u_n)) > 0.0:
        out = moved_state(source, x, s_tgt + (s_raw - s_src), p_src, p_tgt)
        return out, P
    if not _signed_speed(source):
        raise RailnavError(f"the tracks run opposite ways at s = {s_src:.1f} m: an "
                           "inertial filter's state cannot be brought across")
    flip = np.ones(x.size)
    flip[lay.index("v")] = -1.0
    out = x * flip
    out[lay.index("s")] = s_tgt + (s_raw - s_src) * -1.0
    return out, P * np.outer(flip, flip)
