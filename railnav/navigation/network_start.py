"""Where a network run starts: its first hypotheses.

* **Known netelement** (`NetworkStart`, ``railnav run --network N --start E[:OFFSET_M]``):
  hypotheses on that element, at the given offset from its first coordinate, else where
  the start fix projects on it; and on the netelements abreast of it (`with_abreast`).
* **Unknown** (no start): every netelement within `NetworkNavConfig.start_radius_m` of the
  start fix (`trackmodel.network.Network.project`). The start fix is the first position
  fix with a netelement that near (a fix far off every track, a wrong flag or a jump, is
  never a start), or without fixes the first single-point GNSS solution
  (`railnav.navigation.initialization.first_fix`).

Directions: a filter with attitude states (the inertial filters) knows which way the
vehicle faces, so each element gets one hypothesis per orientation; the GNSS-only filter's
speed is signed, so one hypothesis per element covers both ways (its direction of travel
is the sign of ``v``). Each hypothesis starts from the fix projected on its own track
(`Filter.initial_from_fix`; from fixes, `railnav.navigation.fix_start.initial_at_fix`,
whose speed comes from the next fix that agrees with that track), with equal weights.

**Abreast of a known netelement** (`with_abreast`). Told "on B" of a double line, a
navigator with hypotheses on B alone has no other track for the evidence to prefer: it
stays on B with P = 1 whatever the data say (GNSS runs have no fix to spawn from that
tells tracks 4.5 m apart in one window, `railnav.navigation.spawning`). So the
netelements abreast of the known one (`railnav.navigation.network_weights.abreast`:
within `NetworkNavConfig.crossing_radius_m`, travelling the same way; those the crossing
prior links; not those a train passes to or from it, which branching covers) get
hypotheses too, each from a told hypothesis's state brought onto its track
(`railnav.navigation.state_conversion.converted`), together carrying the prior
`NetworkNavConfig.start_abreast_probability` p (shared evenly; the told ones share
1 − p). The weights' evidence decides. Its effect, with ``K`` nats of evidence an epoch
between the tracks (d = 4.5 m, σ_pr = 3 m, 7 GPS satellites: K ≈ 1.1 in closed form for
the epoch alone, 0.86-1.45 measured over 97 s, `benchmarks/bench_parallel_evidence.py`):
a wrong told track is left after about ``ln((1 − p)/p) / K`` epochs (p = 0.01: ~4 s;
measured 3-18 s, `benchmarks/bench_network_spawn_gnss.py` ``parallel``); a right one is
ever given up for a track abreast (its probability above ½) in at most a share
``p/(1 − p)`` of runs (Ville's inequality on the likelihood ratio, a martingale under
the right track; ``right``: one seed of five, for 2 cycles in its first 5 s, where the
ratio of that trip reached e^5.3 against the right track). Cost: the hypothesis abreast
of the right track is never pruned (the crossing prior holds it at ~ε Δt/(1 − e^{−K}),
1.5e-5, above `NetworkNavConfig.prune_probability`), as in a run with no start given:
the navigator's CPU 1.6-2.0× that of the told track alone (0.3-0.4 s more for 97 s).

Not abreast where the start's fix disagrees: a track abreast whose point nearest the
start the start epoch's fix (the position fix, or the epoch's own single-point fix)
rejects, by the spawn test's statistic and p-value (`railnav.navigation.spawning`, as for
a spawn's candidates), gets no hypothesis. Such a start is far along the track from the
train: its copies abreast would be as lost as it is, and the weights between hypotheses
that the data all reject follow the correlation of along- and cross-track errors in the
geometry, not the track (``along`` 150 m without spawning, with the copy: B won, and no
seed of 5 came back within 10 m of the train; without it all 5 do by 24-32 s, the curves
between the loops pulling the lone hypothesis in). The spawn test finds such a train.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.special import chdtrc

from railnav.errors import ConfigError, RailnavError
from railnav.navigation.fix_start import MAX_INITIAL_FIXES, initial_at_fix
from railnav.navigation.hypotheses import Hypothesis, hypothesis
from railnav.navigation.net_tracks import bare
from railnav.navigation.initialization import InitialState, first_fix, noise_seed
from railnav.navigation.loop import EPOCH_TIME_TOL_S
from railnav.navigation.network_weights import abreast, ecef_points, track_points_of
from railnav.navigation.route_path import PathEntry
from railnav.navigation.fix_disagreement import fix_disagreement
from railnav.navigation.spp_epochs import EpochSppFixes
from railnav.navigation.state_conversion import converted
from trackmodel.earth import ecef_to_geodetic
from trackmodel.network_points import points_on

__all__ = ["NetworkStart", "start_hypotheses", "orientations_of", "with_abreast"]

log = logging.getLogger(__name__)

#: Fixes projected on the network at a time while looking for a start.
START_CHUNK = 25


@dataclass(frozen=True)
class NetworkStart:
    """A known start: the netelement (None: every netelement near the start fix, as
    without a start), optionally the offset from its first coordinate (m, with an element)
    and the direction of travel on it (+1 towards its last coordinate, -1 back; None:
    either)."""

    element: str | None
    offset_m: float | None = None
    direction: int | None = None

    def __post_init__(self) -> None:
        if self.direction not in (None, 1, -1):
            raise ConfigError(f"start direction must be +1, -1 or None, got {self.direction!r}")
        if self.element is None and self.offset_m is not None:
            raise ConfigError("a start offset needs the start netelement")


def orientations_of(filt, direction: int | None) -> tuple[int, ...]:
    """The orientations a start on one element needs (module docstring)."""
    if "yaw" not in filt.layout.names:
        return (1,)
    return (1, -1) if direction is None else (direction,)


def _start_fix_index(network, fixes, radius_m: float, element: str | None,
                     after_s: float | None) -> int:
    """The first fix (after `after_s`) with a netelement (`element`, if given) within
    `radius_m`."""
    first = 0 if after_s is None else int(np.searchsorted(fixes.time_s, after_s,
                                                          side="right"))
    n = min(len(fixes) - first, MAX_INITIAL_FIXES)
    if n <= 0:
        raise RailnavError(f"no fix after t={after_s:.1f} s to start again from")
    for k in range(first, first + n, START_CHUNK):    # usually the first chunk has one
        part = slice(k, min(k + START_CHUNK, first + n))
        near = network.project(fixes.lat[part], fixes.lon[part], radius_m=radius_m)
        if element is not None:
            near = near[near["element"] == element]
        if len(near):
            return k + int(near["point"].min())
    where = "a netelement" if element is None else f"netelement {element}"
    raise ConfigError(f"none of the first {n} fixes is within {radius_m:g} m of {where}: "
                      "are the fixes on this network?")


def _candidates(network, lat: float, lon: float, radius_m: float,
                start: NetworkStart | None) -> list[str]:
    if start is not None and start.element is not None:
        return [start.element]
    near = network.project(np.array([lat]), np.array([lon]), radius_m=radius_m)
    if len(near) == 0:
        raise ConfigError(f"the start fix is not within {radius_m:g} m of a netelement: "
                          "is it on this network?")
    return list(dict.fromkeys(near["element"]))


def start_hypotheses(network, tracks, factory, trip, data, config, nav, *,
                     start: NetworkStart | None = None, initial=None,
                     after_s: float | None = None, near=None, seed_scale: bool = False
                     ) -> tuple[float, list[Hypothesis]]:
    """The start time (s from the trip start) and the first hypotheses (module docstring).

    Parameters
    ----------
    network : trackmodel.network.Network
    tracks : railnav.navigation.net_tracks.OrientedTracks
    factory : callable(pieces) -> filter object
    trip : railnav.navigation.navigator.TripSamples
    data : railnav.sensor_data.SensorData
    config : railnav.NavigatorConfig
    nav : railnav.navigation.network_config.NetworkNavConfig
    start : NetworkStart, optional
    initial : callable(filter object, element, orientation) -> InitialState or None, optional
        A start of its own for each candidate (simulations: the truth brought onto it);
        None for a candidate leaves it out.
    after_s : float, optional
        Start from the first fix (or single-point solution) after this time (a restart, s
        from the trip start).
    near : (lat, lon), optional
        Look for candidates near this point (rad) instead of near the start fix (a
        simulation's true start, with `initial`).
    seed_scale : bool
        Seed the bank's noise scale (``factory.noise_scale``) with the start's
        `InitialState.noise_seed` (a run's start and restart; not a spawn's, whose bank
        has its window).

    Raises
    ------
    ConfigError
        A start netelement not in the network; no fix near the network.
    """
    if start is not None and start.element is not None and \
            start.element not in network.elements:
        raise ConfigError(f"start netelement {start.element!r} is not in the network")
    lat, lon, begin = _start_point(network, trip, data, config, nav, start,
                                   near is not None and initial is not None, after_s)
    if near is not None:
        lat, lon = near
    hyps, time_s = [], None
    for element in _candidates(network, float(lat), float(lon), nav.start_radius_m, start):
        probe = factory(bare(element, 1))
        for orientation in orientations_of(probe, None if start is None else start.direction):
            filt = probe if orientation == 1 else factory(bare(element, orientation))
            init = begin(filt) if initial is None else initial(filt, element, orientation)
            if init is None:
                continue
            if start is not None and start.offset_m is not None:
                init = _at_offset(init, filt, tracks, element, orientation, start.offset_m)
            time_s = init.time_s if time_s is None else time_s
            if seed_scale and init.noise_seed and hasattr(factory, "noise_scale"):
                factory.noise_scale.seed(init.noise_seed)
            hyps.append(hypothesis(tracks, bare(element, orientation), init.x0, init.P0,
                                   0.0, filt, (PathEntry(element, orientation,
                                                         float(init.time_s)),)))
    if not hyps:
        raise RailnavError("no start hypothesis")
    if start is not None and start.element is not None and nav.start_abreast_probability:
        hyps = with_abreast(hyps, network, tracks, factory, nav,
                            fix=_fix_at(trip, data, config, float(time_s)),
                            cross_sigma_m=config.fix_model.track_cross_sigma_m)
    log.info("network start at t=%.3f s: %d hypotheses on %s", time_s, len(hyps),
             ", ".join(sorted({h.element for h in hyps})))
    return float(time_s), hyps


def with_abreast(hyps: list[Hypothesis], network, tracks, factory, nav, *, fix=None,
                 cross_sigma_m: float = 0.0) -> list[Hypothesis]:
    """The hypotheses of a start on a known netelement (`hyps`) and those on the
    netelements abreast of them (`_abreast_elements`), with their prior weights (module
    docstring); `hyps` alone when none is abreast or ``nav.start_abreast_probability`` is
    0 (and then every number of the run is the one without abreast hypotheses)."""
    p = nav.start_abreast_probability
    if p == 0.0:
        return hyps
    found: dict[tuple[str, int], Hypothesis] = {}
    for element in _abreast_elements(hyps, network, nav, fix, cross_sigma_m):
        probe = factory(bare(element, 1))
        for orientation in orientations_of(probe, None):
            filt = probe if orientation == 1 else factory(bare(element, orientation))
            for h in hyps:
                try:
                    x, P = converted(h.filt, filt, h.x, h.P)
                except RailnavError:        # the tracks run opposite ways (inertial)
                    continue
                found.setdefault((element, orientation), hypothesis(
                    tracks, bare(element, orientation), x, P, 0.0, filt,
                    (PathEntry(element, orientation, h.path[0].entry_time_s),)))
    both = hyps + list(found.values())
    links = abreast(both, *ecef_points(track_points_of(both)), nav.crossing_radius_m)
    extra = [h for k, h in enumerate(both) if k >= len(hyps)
             and any(j < len(hyps) for j in links[k])]
    if not extra:
        return hyps
    for group, share in ((hyps, 1.0 - p), (extra, p)):
        for h in group:
            h.log_weight = math.log(share / len(group))
    return hyps + extra


def _abreast_elements(hyps: list[Hypothesis], network, nav, fix, cross_sigma_m: float
                      ) -> list[str]:
    """The netelements within ``nav.crossing_radius_m`` of the known start's hypotheses
    but those a train passes to from the known one or comes from there (its continuation
    at a joint, the ways of its switch: branching covers them) and, given the start's
    `fix` (``(fixes, k)``, `_fix_at`), those whose point nearest the start disagrees with
    it (the spawn test's statistic,
    `railnav.navigation.fix_disagreement.fix_disagreement`, with the known start's σ_s
    and `cross_sigma_m`; beyond ``nav.spawn_p_value``: a start that
    the fix puts far along the track is lost, and its copies abreast would be too)."""
    points = track_points_of(hyps)
    near = network.project(np.array([float(q.lat) for q in points]),
                           np.array([float(q.lon) for q in points]),
                           radius_m=nav.crossing_radius_m)
    told = {h.element for h in hyps}
    joined = told | {e for t in told for way in (1, -1) for e, _ in network.successors(t, way)}
    near = near[~near["element"].isin(joined)].drop_duplicates("element")
    if fix is None or near.empty:
        return near["element"].tolist()
    i_s = hyps[0].index("s")
    d2 = fix_disagreement(*ecef_points(points_on([network.elements[e] for e in near["element"]],
                                                 near["s_m"].tolist())),
                          np.full(len(near), math.sqrt(max(hyps[0].P[i_s, i_s], 0.0))),
                          *fix, cross_sigma_m)
    return [e for e, d in zip(near["element"], d2) if chdtrc(2.0, float(d)) >= nav.spawn_p_value]


def _fix_at(trip, data, config, time_s: float):
    """The fix of the epoch at `time_s` (s from the trip start): the position fix, else
    that GNSS epoch's own single-point fix (`railnav.navigation.spp_epochs`), as
    ``(fixes, k)``; None without one."""
    spp = None
    if trip.fixes is not None and len(trip.fixes):
        fixes = trip.fixes
    else:
        spp = EpochSppFixes.of(trip.gnss, data, config)
        if spp is None:
            return None
        fixes = spp.fixes
    k = int(np.argmin(np.abs(np.asarray(fixes.time_s, dtype=float) - time_s)))
    if abs(float(fixes.time_s[k]) - time_s) > EPOCH_TIME_TOL_S:
        return None
    if spp is not None:
        spp.solve(k)
    return (fixes, k) if np.isfinite(fixes.lat[k]) else None


def _start_point(network, trip, data, config, nav, start, told: bool, after_s):
    """Where the candidates are looked for (lat, lon, rad) and how a candidate's filter
    starts there (``begin(filt) -> InitialState``); `told`: every candidate's start is
    given (a simulation)."""
    if told:
        def begin(filt):                       # never called: the starts are given
            raise RailnavError("no start")
        return 0.0, 0.0, begin
    if trip.fixes is not None and len(trip.fixes):
        k = _start_fix_index(network, trip.fixes, nav.start_radius_m,
                             None if start is None or start.offset_m is not None
                             else start.element, after_s)

        def begin(filt):
            return initial_at_fix(filt, trip.fixes, k, config)
        return float(trip.fixes.lat[k]), float(trip.fixes.lon[k]), begin
    if trip.gnss is not None:
        fix = first_fix(_after(data, trip.gnss, after_s), config)
        lat, lon, _ = ecef_to_geodetic(fix.r_e)

        def begin(filt):
            return InitialState(fix.time_s, *filt.initial_from_fix(fix),
                                noise_seed=noise_seed(fix))
        return float(lat), float(lon), begin
    raise RailnavError("a network run needs GNSS observations or fixes to start from")


def _after(data, gnss, after_s: float | None):
    """`data` with the GNSS observations from the run's first usable epoch after `after_s`
    on (s from the trip start; usable: outside the outages, `gnss`'s epochs)."""
    if after_s is None:
        return data
    usable = np.asarray(gnss.time_s, dtype=float)
    usable = usable[usable > after_s]
    if usable.size == 0:
        raise RailnavError(f"no GNSS epoch after t={after_s:.1f} s to start again from")
    table = data.obs.table
    keep = table["gps_time_s"].to_numpy() >= data.start_gps_time_s + usable[0] - 1e-6
    return replace(data, obs=replace(data.obs, table=table[keep]))


def _at_offset(init: InitialState, filt, tracks, element: str, orientation: int,
               offset_m: float) -> InitialState:
    length = tracks.length_m(element)
    if not 0.0 <= offset_m <= length:
        raise ConfigError(f"start offset {offset_m:g} m is not on netelement {element} "
                          f"(length {length:.1f} m)")
    x0 = np.array(init.x0, dtype=float)
    x0[filt.layout.index("s")] = tracks.s_of_offset(element, orientation, offset_m)
    return replace(init, x0=x0)
