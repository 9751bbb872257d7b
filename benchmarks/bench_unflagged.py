"""The urban drive's epochs beyond 3σ_s, one by one: how near the divergence monitor's
tests came, what SPP said, and what the rover's own carrier phase says (issue 14: "the
monitor flags every epoch whose error exceeds 3σ").

Data: the full urban drive, ``--data DIR`` (provenance in ``data/gnss/README.md``). The
pieces, filters and scoring are `bench_real_pieces.py`'s (`bench_real_pieces.solve_piece`).
For each filter (``gnss-only``, ``fixes``) and each of its epochs with the along-track
error ``e_s`` (the state ``s`` against the reference projected on the piece's track)
beyond 3σ_s:

* the monitor's status and its window's tail probabilities at that epoch (the smallest of
  them names the test nearest to firing; ``p_degraded`` is 1e-3), and this epoch's fix
  disagreement ``d`` (σ);
* SPP's along-track error (GPS L1, `gnss_obs.solve_spp`, projected on the same track);
* the **carrier chain**: the reference's ``s`` at an anchor epoch before (the last with
  ``|z| <`` `ANCHOR_MAX_Z`) plus the rover's own along-track distance since, second by
  second: its GPS+Galileo L1 carrier displacement (TDCP, `bench_doppler_carrier`, 7 mm
  residual) or, on seconds without one, the GPS+Galileo single-point Doppler speed's
  trapezoid (0.12 m/s RMS white against the carrier). ``e_chain`` is the filter's ``s``
  against that: independent of the reference after the anchor;
* the code-bias state's statistic ``z_b = b / √(1 − σ_b²)`` (a consistent filter's
  estimate of a unit-variance state has variance ``1 − σ_b²``);
* a cause, by the first rule that holds (`cause`): ``start`` (within `START_S` of the
  piece's first epoch), ``reference`` (the carrier chain puts the filter within
  `CHAIN_AGREES_SIGMA` σ_s: the reference and the rover's own carrier disagree),
  ``tight corner`` (a radius under `bench_real_pieces.TIGHTEST_TRACK_RADIUS_M` within
  `CORNER_REACH_M` of the reference's ``s``), ``SPP shares it`` (SPP's along-track error
  of the same sign and at least `SPP_SHARES_SIGMA` σ_s), else ``off the line``.

Also the trade-off of the one candidate test that needs no new measurement, the code-bias
state against its prior (``|z_b|`` beyond 2, 2.58, 3.29: two-sided 4.6e-2, 1e-2, 1e-3):
how many unflagged epochs beyond 3σ_s it would flag, and how many of the ``ok`` epochs
within 3σ_s (false alarms), for each filter.

Writes ``benchmarks/results/unflagged.json`` (``--out``). ``--heading-curvature-m D``:
the filters with ``NavigatorConfig.track_heading_curvature_m`` = D. Run: ``python
benchmarks/bench_unflagged.py --data DIR`` (a few minutes).
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _data_dir import add_data_argument, checked_data_dir  # noqa: E402
from bench_doppler_carrier import drive_velocities  # noqa: E402
from bench_real_pieces import (  # noqa: E402
    DATA_FILES,
    TIGHTEST_TRACK_RADIUS_M,
    bench_config,
    load_drive,
    pieces,
    solve_piece,
)

from trackmodel.files import atomic_write_text  # noqa: E402
from tests.support.track_offsets import along_track_s  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "unflagged.json"
#: The carrier chain starts at the last epoch before with |z| below this.
ANCHOR_MAX_Z = 1.0
#: Epochs this close to a piece's first one are its start, s.
START_S = 5.0
#: The filter within this many σ_s of the carrier chain: the reference is the odd one out.
CHAIN_AGREES_SIGMA = 1.5
#: How far along the track a corner tighter than the tightest track radius counts, m.
CORNER_REACH_M = 10.0
#: SPP "shares" an error of the same sign at least this many σ_s.
SPP_SHARES_SIGMA = 1.5
#: ``|z_b|`` levels of the code-bias test (two-sided 4.6e-2, 1e-2, 1e-3).
Z_B_LEVELS = (2.0, 2.576, 3.29)
#: The monitor's window tests (`railnav.navigation.monitor.FilterMonitor.frame`).
TAILS = ("p_gnss_nis", "p_rejected", "p_fix", "p_pseudo_nis", "p_fix_small",
         "p_kind_rejected")
GPS_WEEK_S = 2134 * 604_800


def along_track_steps(track, s_m: pd.Series, velocities: pd.DataFrame
                      ) -> tuple[pd.Series, pd.Series]:
    """The rover's along-track distance over each second ``[t-1, t]`` (m), and whether it is
    the carrier's (else the GPS+Galileo Doppler speeds' trapezoid).

    Parameters
    ----------
    track : trackmodel.Track
    s_m : Series
        The filter's ``s`` (m) by second of week: where the track's tangent is taken.
    velocities : DataFrame
        `bench_doppler_carrier.velocities` by second of week (``Tbe, Tbn``: the carrier's
        displacement over the second before, m; ``Ge, Gn``: the Doppler velocity, m/s).
    """
    seconds = np.arange(int(s_m.index.min()), int(s_m.index.max()) + 1)
    u_n = track.at(np.clip(s_m.to_numpy(), 0.0, track.length_m)).u_n[:, :2]
    u_n = u_n / np.linalg.norm(u_n, axis=1)[:, None]
    tangent = pd.DataFrame(u_n, index=s_m.index, columns=["e", "n"]).reindex(seconds)
    tangent = tangent.interpolate(limit_direction="both")
    v = velocities.reindex(seconds)
    carrier = v["Tbe"] * tangent["e"] + v["Tbn"] * tangent["n"]
    doppler = v["Ge"] * tangent["e"] + v["Gn"] * tangent["n"]
    return carrier.fillna(0.5 * (doppler + doppler.shift(1))), carrier.notna()


def chain_errors(epochs: pd.DataFrame, steps: pd.Series, is_carrier: pd.Series
                 ) -> pd.DataFrame:
    """``anchor_sow, carrier_seconds, seconds, e_chain_m`` of each epoch beyond 3σ_s of
    `epochs` (indexed by second of week, with ``s_ref, e_s, z``): the module docstring's
    carrier chain from the last epoch before with ``|z| <`` `ANCHOR_MAX_Z` and every second
    since measured; NaN without one."""
    rows = []
    calm = epochs.index[np.abs(epochs["z"]) < ANCHOR_MAX_Z]
    for t in epochs.index[np.abs(epochs["z"]) > 3.0]:
        anchors = [a for a in calm[calm < t] if steps.loc[a + 1:t].notna().all()]
        if not anchors:
            rows.append((t, np.nan, 0, 0, np.nan))
            continue
        a = max(anchors)
        excess = epochs.at[t, "s_ref"] - epochs.at[a, "s_ref"] - steps.loc[a + 1:t].sum()
        rows.append((t, a, int(is_carrier.loc[a + 1:t].sum()), int(t - a),
                     float(epochs.at[t, "e_s"] + excess)))
    return pd.DataFrame(rows, columns=["sow", "anchor_sow", "carrier_seconds", "seconds",
                                       "e_chain_m"]).set_index("sow")


def piece_epochs(piece: dict, obs, nav, reference: pd.DataFrame, spp: pd.DataFrame,
                 velocities: pd.DataFrame, workdir: Path, config) -> dict:
    """Per filter, its epochs of one piece (indexed by second of week): error, σ, status,
    the monitor's tails, SPP's error, ``z_b`` and the carrier chain (module docstring)."""
    solutions, results, (t0, _) = solve_piece(piece, obs, nav, reference, spp, workdir,
                                              config)
    track = piece["track"]
    ref = reference.set_index(np.round(reference["gps_time_s"] - GPS_WEEK_S).astype(int))
    fixes = spp.set_index(np.round(spp["gps_time_s"] - GPS_WEEK_S).astype(int))
    fixes = fixes[~fixes.index.duplicated()]
    out = {}
    for name in ("gnss-only", "fixes"):
        est = solutions[name].set_index(np.round(solutions[name]["gps_time_s"]
                                                 - GPS_WEEK_S).astype(int))
        mon = results[name].monitor
        mon = mon.set_index(np.round(mon["time_s"] + t0 - GPS_WEEK_S).astype(int))
        est = est.join(mon[[*TAILS, "fix_disagreement_sigma"]], how="left")
        est = est.loc[est.index.intersection(ref.index)]
        r = ref.loc[est.index]
        est["s_ref"] = along_track_s(track, r["lat_deg"], r["lon_deg"])
        both = est.index.intersection(fixes.index)
        f = fixes.loc[both]
        est["spp_e_s"] = pd.Series(track.project(np.radians(f["lat_deg"].to_numpy()),
                                                 np.radians(f["lon_deg"].to_numpy())).s,
                                   index=both) - est["s_ref"]
        est["e_s"] = est["s_state_m"] - est["s_ref"]
        est["z"] = est["e_s"] / est["sigma_s_m"]
        est["z_b"] = est["code_bias"] / np.sqrt(np.maximum(
            1.0 - est["sigma_code_bias"] ** 2, 1e-12)) if "code_bias" in est else np.nan
        est["since_start_s"] = est.index - (t0 - GPS_WEEK_S)
        steps, is_carrier = along_track_steps(track, est["s_state_m"], velocities)
        out[name] = est.join(chain_errors(est, steps, is_carrier), how="left")
    return out


def cause(row: pd.Series, track) -> str:
    """The first rule of the module docstring that holds for an epoch beyond 3σ_s."""
    sigma = row["sigma_s_m"]
    if row["since_start_s"] <= START_S:
        return "start"
    if np.isfinite(row["e_chain_m"]) and abs(row["e_chain_m"]) < CHAIN_AGREES_SIGMA * sigma:
        return "reference"
    s = np.clip(row["s_ref"] + np.arange(-CORNER_REACH_M, CORNER_REACH_M + 0.5, 1.0), 0.0,
                track.length_m)
    if np.abs(track.at(s).curvature_1pm).max() > 1.0 / TIGHTEST_TRACK_RADIUS_M:
        return "tight corner"
    if np.sign(row["spp_e_s"]) == np.sign(row["e_s"]) and \
            abs(row["spp_e_s"]) >= SPP_SHARES_SIGMA * sigma:
        return "SPP shares it"
    return "off the line"


def _record(sow: int, row: pd.Series, label: str) -> dict:
    """One epoch beyond 3σ_s, as the JSON lists it."""
    tails = {k: float(row[k]) for k in TAILS}
    nearest = min(tails, key=tails.get)
    return {"sow": int(sow), "status": str(row["status"]), "cause": label,
            "e_s_m": float(row["e_s"]), "sigma_s_m": float(row["sigma_s_m"]),
            "z": float(row["z"]), "nearest_test": nearest, "nearest_tail": tails[nearest],
            "fix_disagreement_sigma": float(row["fix_disagreement_sigma"]),
            "spp_e_s_m": float(row["spp_e_s"]), "z_b": float(row["z_b"]),
            "e_chain_m": float(row["e_chain_m"]),
            "z_chain": float(row["e_chain_m"] / row["sigma_s_m"]),
            "chain_anchor_sow": float(row["anchor_sow"]),
            "chain_carrier_seconds": f"{int(row['carrier_seconds'])}/{int(row['seconds'])}"}


def summarize(epochs: dict, tracks: dict) -> dict:
    """Per filter: epochs beyond 3σ_s and unflagged, by cause and by piece, each of them
    (`_record`), and the code-bias test's trade-off at `Z_B_LEVELS`."""
    out = {}
    for name in ("gnss-only", "fixes"):
        records, flags = [], {z: [0, 0] for z in Z_B_LEVELS}
        by_piece, by_cause = {}, {}
        within_ok = 0
        for piece, frames in epochs.items():
            e = frames[name]
            beyond, ok = np.abs(e["z"]) > 3.0, e["status"] == "ok"
            within_ok += int((~beyond & ok).sum())
            by_piece[piece] = [int(beyond.sum()), int((beyond & ok).sum())]
            for z in Z_B_LEVELS:
                fires = np.abs(e["z_b"]) > z
                flags[z][0] += int((fires & beyond & ok).sum())
                flags[z][1] += int((fires & ~beyond & ok).sum())
            for sow, row in e[beyond].iterrows():
                label = cause(row, tracks[piece])
                records.append({"piece": piece, **_record(sow, row, label)})
                if row["status"] == "ok":
                    by_cause[label] = by_cause.get(label, 0) + 1
        out[name] = {
            "epochs_beyond_3sigma": len(records),
            "epochs_beyond_3sigma_not_flagged": sum(by_cause.values()),
            "not_flagged_by_cause": by_cause,
            "by_piece_beyond_and_not_flagged": by_piece,
            "code_bias_test": {f"|z_b| > {z}": {"flags_not_flagged": a,
                                                "false_alarms_ok_within_3sigma": b,
                                                "ok_within_3sigma": within_ok}
                               for z, (a, b) in flags.items()},
            "epochs": records}
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_data_argument(parser, DATA_FILES)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--heading-curvature-m", type=float, default=None,
                        help="NavigatorConfig.track_heading_curvature_m of the filters "
                             "(default: the configuration's, 0)")
    args = parser.parse_args(argv)
    config = bench_config()
    if args.heading_curvature_m is not None:
        config = replace(config, track_heading_curvature_m=args.heading_curvature_m)
    data = checked_data_dir(parser, args.data, DATA_FILES)
    started = time.perf_counter()
    obs, nav, reference, spp = load_drive(data)
    *_, velocities = drive_velocities(obs, nav, reference)
    epochs, tracks = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for piece in pieces(reference):
            tracks[piece["name"]] = piece["track"]
            epochs[piece["name"]] = piece_epochs(piece, obs, nav, reference, spp, velocities,
                                                 Path(tmp), config)
    out = {"data": "gnss_urban_drive",
           "track_heading_curvature_m": config.track_heading_curvature_m,
           "rules": {"anchor_max_z": ANCHOR_MAX_Z, "start_s": START_S,
                     "chain_agrees_sigma": CHAIN_AGREES_SIGMA,
                     "corner_radius_m": TIGHTEST_TRACK_RADIUS_M,
                     "corner_reach_m": CORNER_REACH_M, "spp_shares_sigma": SPP_SHARES_SIGMA},
           "filters": summarize(epochs, tracks),
           "seconds": time.perf_counter() - started, "machine": platform.platform()}
    for name, f in out["filters"].items():
        print(f"{name}: beyond 3σ {f['epochs_beyond_3sigma']}, not flagged "
              f"{f['epochs_beyond_3sigma_not_flagged']}: {f['not_flagged_by_cause']}; "
              f"code-bias test {f['code_bias_test']}")
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    print(f"{args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
