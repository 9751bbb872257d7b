"""Scores of a network run against its netelement truth (issue 13).

The truth is the netelement the train was on: at the points of a reference file
(`netelement_truth_of`: ``railnav simulate``'s ``truth.csv``, a reference trajectory or a
fix file's carrier-fixed rows, placed on the network by
`railnav.evaluation.netelement_truth.netelement_truth`), or along a simulated route
(`true_netelements`). `scored_summary` adds to a run's ``summary.json`` its ``route`` block
with the netelement scores per cycle and the route check
(`railnav.evaluation.netelement_truth`). `railnav.jobs.network`'s runs use them.
"""
from __future__ import annotations

import numpy as np

from railnav.errors import ConfigError
from railnav.evaluation.netelement_truth import (
    collapse,
    netelement_scores,
    netelement_truth,
    route_passes,
)
from trackmodel.network import Network

__all__ = ["scored_summary", "netelement_truth_of", "true_netelements"]


def scored_summary(summary: dict, result, network, truth_time_s, truth, extra: dict) -> dict:
    """`summary` with ``route`` (`NetworkResult.route_summary`) and, with a truth, its
    netelement scores and route check."""
    route = result.route_summary()
    if truth is not None:
        cyc = result.cycles
        route["truth"] = netelement_scores(cyc["time_s"], cyc["netelement"],
                                           cyc["netelement_probability"], truth_time_s, truth)
        frame = result.route_frame()
        route["truth"].update(route_passes(network, zip(frame["netelement"],
                                                        frame["orientation"]),
                                           collapse(truth)))
    route.update(extra)
    return {**summary, "route": route}


def netelement_truth_of(network, truth_path, quality, start_gps_time_s: float):
    """Issue 13's netelement truth (`railnav.evaluation.netelement_truth`) at the points
    of a reference file (`railnav.evaluation.reference.reference_kind`): ``railnav
    simulate``'s ``truth.csv`` (every sample), a reference trajectory (every row) or a fix
    file (its rows of class `quality`, default ``rtk_fixed``). Times (s from the trip
    start) and netelements (None where ambiguous)."""
    import pandas as pd

    from gnss_obs.fixes.read import read_fixes
    from railnav.evaluation.reference import reference_kind
    from railnav.evaluation.spp_accuracy import read_reference_trajectory
    kind = reference_kind(truth_path, quality)
    if kind == "truth":
        tab = pd.read_csv(truth_path)
        missing = {"time_s", "lat_deg", "lon_deg"} - set(tab.columns)
        if missing:
            raise ConfigError(f"truth file without {', '.join(sorted(missing))}",
                              path=truth_path)
        time_s = tab["time_s"].to_numpy(dtype=float)
    else:
        tab = read_reference_trajectory(truth_path) if kind == "trajectory" else \
            read_fixes(truth_path).table
        time_s = tab["gps_time_s"].to_numpy(dtype=float) - start_gps_time_s
    truth = netelement_truth(network, np.radians(tab["lat_deg"].to_numpy(dtype=float)),
                             np.radians(tab["lon_deg"].to_numpy(dtype=float)))
    if kind == "fixes":
        truth[tab["quality"].to_numpy() != (quality or "rtk_fixed")] = None
    return time_s, truth


def true_netelements(network: Network, legs, s_m) -> np.ndarray:
    """The netelement of each distance `s_m` along the chained legs of a route (None
    beyond its ends)."""
    ends = np.cumsum([network.length_m(e) for e, _ in legs])
    k = np.searchsorted(ends, np.asarray(s_m, dtype=float), side="right")
    names = np.array([e for e, _ in legs] + [None], dtype=object)
    out = names[np.minimum(k, len(legs))]
    out[np.asarray(s_m) < 0.0] = None
    return out
