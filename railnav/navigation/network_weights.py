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
   abreast estimates brought onto its own track (`railnav.navigation.state_conversion`),
   weighted ``μ_{i|j} = Π_ij μ_i / c_j`` (`ekf.bank.imm_starts`), so that the filter on an
   unlikely parallel track follows the likely one instead of drifting on its own wrong
   geometry, ready if the train does cross.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from ekf.bank import imm_mixing, imm_starts, log_predict, uniform_switching
from railnav.navigation.bank import common_log_likelihoods, evidence_rows
from railnav.navigation.hypothesis_step import common_continuous_log_likelihoods
from railnav.navigation.state_conversion import converted_pairs, known_offsets, signed_speed
from trackmodel.earth import C_n_e
from trackmodel.network_points import point_fields, points_on

__all__ = ["cycle_evidence", "hypothesis_points", "ecef_points", "track_points_of",
           "cycle_points", "abreast", "crossing_matrix", "reweight", "mix_states"]

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
        common = evidence_rows(outcome.screens)
        log_lik = log_lik + share * common_log_likelihoods(outcome.screens, common)
        rows = len(common)
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
    lat, lon, r, u_n = point_fields(points, "lat", "lon", "r_e", "u_n")
    lat, lon, r, u_n = lat.reshape(-1), lon.reshape(-1), r.reshape(-1, 3), u_n.reshape(-1, 3)
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
    ordered pair ``(i, j)`` whose pair of tracks has an offset (`known_offsets`), the point of
    j's track at ``s_i`` plus that offset, clamped, as ``{(i, j): (s_g, point)}`` (the
    same numbers as evaluated there: `points_on` is pure per point)."""
    tracks = [h.filt.track for h in hyps]
    s = [min(max(h.s_m, 0.0), t.length_m) for h, t in zip(hyps, tracks)]
    found = known_offsets(tracks)
    pairs = [(i, j) for i, j, _ in found]
    s_g = [min(max(s[i] + offset, 0.0), tracks[j].length_m) for i, j, offset in found]
    both = points_on(tracks + [tracks[j] for _, j in pairs], s + s_g)
    return both[:len(hyps)], {p: (g, q) for p, g, q in zip(pairs, s_g, both[len(hyps):])}


def abreast(hyps, r_e: Array, tangent_e: Array, radius_m: float) -> list[list[int]]:
    """For each hypothesis, the others abreast of it (module docstring, 2): on another
    element or orientation, within `radius_m` (3-D distance of the track points), with
    tangents pointing the same way (either way for filters whose speed is signed)."""
    K = len(hyps)
    out: list[list[int]] = [[] for _ in range(K)]
    if K < 2:
        return out
    d = np.linalg.norm(r_e[:, None, :] - r_e[None, :, :], axis=2)
    same_way = (tangent_e @ tangent_e.T > 0.0) | signed_speed(hyps[0].filt)
    codes: dict[tuple, int] = {}
    on = np.array([codes.setdefault(h.where()[:2], len(codes)) for h in hyps])
    # i != j follows from another element or orientation
    linked = (d <= radius_m) & same_way & (on[:, None] != on[None, :])
    return [[j for j, yes in enumerate(row) if yes] for row in linked.tolist()]


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
    if K < 2 or _identity(transition):
        return
    mixing = imm_mixing(mu, transition, min_weight)
    uses = mixing[1]
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
                        convert=convert, min_weight=min_weight, mixing=mixing)
    for h, x, P in zip(hyps, x0, P0):
        h.x, h.P = np.asarray(x, dtype=float), np.asarray(P, dtype=float)


def _identity(transition: Array) -> bool:
    """``np.allclose(transition, np.eye(K))``: ``|Π − I| ≤ 1e-8 + 1e-5 I`` everywhere
    (NaN and inf not), without `np.isclose`'s broadcasting and checks."""
    eye = np.eye(transition.shape[0])
    return bool(np.all(np.abs(transition - eye) <= 1e-8 + 1e-5 * eye))
