"""The filters' speed and along-track error against the rover's own carrier phase, piece by
piece over the urban drive (issue 14; the measurements: ``bench_doppler_carrier.py``).

Per piece of ``bench_real_pieces.py`` (its tracks, its filter configuration), the gnss-only
filter's speed ``|v|`` at each second against the carrier's (GPS+Galileo L1C, time-differenced,
`_carrier_phase.tdcp`) on the seconds faster than
`bench_doppler_carrier.MIN_SPEED_MPS`: the mean and RMS difference and the instant it
matches, ``t - τ`` (`bench_doppler_carrier.doppler_instant`: a lagging speed has τ > 0).

Per window of `bench_doppler_carrier.WINDOWS` inside a piece (a second without a carrier
solution takes the GPS+Galileo Doppler's mean over it: ``seconds_from_doppler``), the
change of the filter's
along-track error in distance travelled, ``Δe = |Δs_filter| - |Δs_reference|`` (m, negative:
the filter behind), split into three parts that add up to it:

* ``speed``: ``Σ (|v(t-1)| + |v(t)|)/2 - Σ carrier``, the filter's speed, integrated,
  against the carrier's distance (the Doppler's share, through the filter);
* ``reference``: ``Σ carrier - |Δs_reference|``, the carrier's distance against the
  reference's along the track (``reference_chord_m``, of it: against the reference's own
  distance, second by second; the rest is the projection on the fitted track);
* ``updates``: the rest, ``|Δs_filter| - Σ (|v(t-1)| + |v(t)|)/2``, what the
  measurement updates moved ``s`` beyond its own speed (code rows, heading rows,
  recoveries).

``--oracle central|causal`` reruns ``bench_real_pieces`` with the GPS/Galileo L1 Doppler
replaced by carrier range rates (``central``: ``λ(L(t+1) - L(t-1))/2``, not causal, the best
range rate the data hold; ``causal``: ``λ(1.5 ΔL(t) - 0.5 ΔL(t-1))``), ``--oracle-sigma-rr``
the filters' ``sigma_rr_mps`` with it: what a carrier range-rate row could buy.

Findings (``results/doppler_filters.json``, ``--oracle central``):

* The gnss-only filter's speed does not lag the carrier's on any piece: τ between -0.16
  and +0.03 s (-0.16 on leg 1 part 4, 23 s, RMS 0.26 m/s there; -0.018 on leg 1, 229 s),
  mean -0.042 ... +0.012 m/s, RMS 0.10-0.26 m/s.
* 45966-45983 (17 s, 2 of them from the Doppler), in the three pieces that hold it: the
  filter falls behind the reference by 2.50 / 1.70 / 2.98 m (leg 1 / leg 1 part 6 / the
  U-turn piece); of that its speed against the carrier -0.65 / -0.79 / -0.75 m, the
  carrier against the reference -0.83 / -0.76 / -0.98 m (-0.54 m of it the reference's
  own distance, the rest its projection on the fitted track), the updates -1.02 / -0.14
  / -1.25 m. Leg 1's 45740-45780 has no carrier on 23 of its seconds.
* Carrier range rates in place of the Doppler, at the filters' σ (``central``): the U-turn
  piece 2.37/5.79 → 2.12/4.45 m (RMS/max; SPP 2.90/3.82), leg 2 1.03/2.03 → 0.76/1.36,
  leg 1 1.65/5.78 → 1.51/5.12, but leg 1 part 3 3.20/4.95 → 3.47/6.22, part 5
  0.78/2.27 → 1.11/2.55, part 6 1.53/3.42 → 1.61/4.09; ``causal``: the U-turn piece
  2.06/4.51, part 4 2.71/5.49 → 3.07/5.61. At σ 0.01 m/s (``--oracle-sigma-rr 0.01``,
  what the carrier's noise would allow) the filters fail: leg 1 8.47/38.28 m, the
  U-turn piece 4.06/13.02. A perfect range rate does not bring the U-turn piece under
  SPP's maximum; the rest of its error is in the code rows and the track (the updates).

Writes ``benchmarks/results/doppler_filters.json``. Run: ``python
benchmarks/bench_doppler_filters.py --data DIR`` (about a minute).
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_doppler_carrier as dc  # noqa: E402
import bench_real_pieces as rp  # noqa: E402
from _carrier_phase import L1_HZ, carrier_rates  # noqa: E402
from _data_dir import add_data_argument, checked_data_dir  # noqa: E402

from gnss_obs.constants import SPEED_OF_LIGHT_MPS  # noqa: E402
from railnav.navigation.navigator import navigate  # noqa: E402
from railnav.sensor_data import SensorData  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "doppler_filters.json"


def filter_run(piece: dict, obs, nav, reference: pd.DataFrame) -> pd.DataFrame:
    """The gnss-only filter on one piece, per whole second of week: ``s``, ``v`` (the
    states), ``sigma_s_m`` and the reference's ``s`` on the piece's track."""
    times = reference["gps_time_s"].to_numpy()[piece["rows"]]
    t0, t1 = float(times[0]), float(times[-1])
    table = obs.table
    piece_obs = replace(obs, table=table[(table["gps_time_s"] >= t0 - 1e-6)
                                         & (table["gps_time_s"] <= t1 + 1e-6)])
    result = navigate(piece["track"], SensorData(start_gps_time_s=t0, obs=piece_obs, nav=nav),
                      rp.bench_config())
    est = rp._at_epochs(result.estimates.assign(
        s=result.x[:, result.layout.index("s")], v=result.x[:, result.layout.index("v")]))
    est = est.set_index(np.round(est["gps_time_s"]).astype(np.int64) - dc.GPS_WEEK_S)
    ref = reference.set_index(np.round(reference["gps_time_s"]).astype(np.int64)
                              - dc.GPS_WEEK_S)
    s_ref = piece["track"].project(np.radians(ref["lat_deg"].to_numpy()),
                                   np.radians(ref["lon_deg"].to_numpy())).s
    est["s_ref"] = pd.Series(s_ref, index=ref.index).reindex(est.index)
    return est[["s", "v", "sigma_s_m", "s_ref"]]


def speed_against_carrier(est: pd.DataFrame, al: pd.DataFrame) -> dict:
    """`bench_doppler_carrier.doppler_instant` of the filter's speed against the carrier."""
    a = al.join(est["v"].abs().rename("F"), how="inner")
    a = a[a[["F", "Tb", "Tf"]].notna().all(axis=1)]
    if len(a) < 3:
        return {"n": int(len(a))}
    return dc.doppler_instant(a["F"].to_numpy(), a["Tb"].to_numpy(), a["Tf"].to_numpy())


def window_split(est: pd.DataFrame, carrier_m: pd.Series, reference_m: pd.Series, a: int,
                 b: int) -> dict | None:
    """The module docstring's split of ``Δe`` from second `a` to `b`, `carrier_m` the
    carrier's and `reference_m` the reference's horizontal distance over each second
    ``[t-1, t]`` (``reference_chord_m``: the reference's own distance against the carrier's,
    the rest of ``reference_m`` is the projection on the track); None unless the piece has
    the filter and the reference at both ends."""
    if a not in est.index or b not in est.index or \
            not np.isfinite(est.loc[[a, b], "s_ref"]).all():
        return None
    seconds = np.arange(a + 1, b + 1)
    speed = est["v"].abs().reindex(np.arange(a, b + 1))
    trapezoid = float((0.5 * (speed.shift(1) + speed)).loc[seconds].sum())
    carrier = carrier_m.reindex(seconds)
    d_filter = abs(est.at[b, "s"] - est.at[a, "s"])
    d_ref = abs(est.at[b, "s_ref"] - est.at[a, "s_ref"])
    missing = int(carrier.isna().sum())
    # without the carrier on every second, its distance and so the first two parts are unknown
    distance = float(carrier.sum()) if not missing else float("nan")
    return {"seconds": [a, b], "carrier_seconds_missing": missing,
            "delta_e_m": float(d_filter - d_ref), "speed_m": trapezoid - distance,
            "reference_m": distance - d_ref, "updates_m": d_filter - trapezoid,
            "reference_chord_m": distance - float(reference_m.reindex(seconds).sum(
                min_count=len(seconds))),
            "e_s_start_m": float(est.at[a, "s"] - est.at[a, "s_ref"]),
            "e_s_end_m": float(est.at[b, "s"] - est.at[b, "s_ref"])}
def carrier_doppler(table: pd.DataFrame, mode: str) -> pd.DataFrame:
    """`table` with the GPS/Galileo L1C Doppler replaced, where the carrier allows, by the
    carrier range rate (module docstring, ``--oracle``), in Hz."""
    rates = carrier_rates(table)
    rates = rates[rates["signal"] == "1C"].set_index(["t", "sv"])
    if mode == "causal":
        prev = rates["back"].rename(lambda k: k, level=0)
        prev.index = pd.MultiIndex.from_arrays([prev.index.get_level_values(0) + 1,
                                                prev.index.get_level_values(1)])
        rate = (1.5 * rates["back"] - 0.5 * prev.reindex(rates.index)).dropna()
    else:
        rate = 0.5 * (rates["back"] + rates["fwd"])
    out = table.copy()
    key = pd.MultiIndex.from_arrays([np.round(out["gps_time_s"]).astype(np.int64), out["sv"]])
    new = rate.reindex(key).to_numpy()
    use = (out["signal"].to_numpy() == "1C") & np.isfinite(new)
    out.loc[use, "doppler_hz"] = -new[use] * L1_HZ / SPEED_OF_LIGHT_MPS
    return out


def oracle(obs, nav, reference: pd.DataFrame, spp: pd.DataFrame, mode: str,
           sigma_rr_mps: float | None) -> dict:
    """`bench_real_pieces` on the drive with `carrier_doppler`'s table (the SPP fixes of
    the fix-based filter stay the Doppler's)."""
    config = rp.bench_config()
    if sigma_rr_mps is not None:
        config = replace(config, measurement=replace(config.measurement,
                                                     sigma_rr_mps=sigma_rr_mps))
    patched = replace(obs, table=carrier_doppler(obs.table, mode))
    results = rp.run_pieces(patched, nav, reference, spp, config)
    return {"mode": mode, "sigma_rr_mps": config.measurement.sigma_rr_mps,
            "pieces": {name: {k: r[k] for k in ("epochs", "gnss-only", "spp")}
                       for name, r in results.items()}}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_data_argument(parser, rp.DATA_FILES)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--oracle", choices=("central", "causal"), default=None)
    parser.add_argument("--oracle-sigma-rr", type=float, default=None,
                        help="the filters' sigma_rr_mps with --oracle (default: theirs)")
    args = parser.parse_args(argv)
    data = checked_data_dir(parser, args.data, rp.DATA_FILES)
    started = time.perf_counter()
    obs, nav, reference, spp = rp.load_drive(data)
    _, _, v = dc.drive_velocities(obs, nav, reference)
    al = dc.along_track(v)
    carrier_m, reference_m, doppler = (pd.Series(np.linalg.norm(
        v[[f"{p}e", f"{p}n"]].to_numpy(), axis=1), index=v.index) for p in ("Tb", "Rb", "G"))
    # a second without a carrier solution: the GPS+Galileo Doppler's mean over it
    filled = carrier_m.isna() & (0.5 * (doppler + doppler.shift(1))).notna()
    carrier_m = carrier_m.fillna(0.5 * (doppler + doppler.shift(1)))
    pieces = {}
    for piece in rp.pieces(reference):
        est = filter_run(piece, obs, nav, reference)
        splits = {name: window_split(est, carrier_m, reference_m, a, b)
                  for name, (a, b) in dc.WINDOWS.items()}
        for name, w in splits.items():
            if w:
                w["seconds_from_doppler"] = int(filled.loc[w["seconds"][0] + 1:
                                                           w["seconds"][1]].sum())
        pieces[piece["name"]] = {"speed": speed_against_carrier(est, al),
                                 "windows": {k: w for k, w in splits.items() if w}}
        print(piece["name"], json.dumps(pieces[piece["name"]]), flush=True)
    out = {"data": "gnss_urban_drive", "pieces": pieces}
    if args.oracle:
        out["oracle"] = oracle(obs, nav, reference, spp, args.oracle, args.oracle_sigma_rr)
    out.update(seconds=time.perf_counter() - started, machine=platform.platform())
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
