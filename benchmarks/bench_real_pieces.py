"""Every piece of the shared urban drive: GNSS-only and fix-based filters against SPP, and
the divergence monitor's flags (issue 14, acceptance on real data).

Data: the full urban drive, ``--data DIR`` (rover 2020-11-29 12:40-12:48 GPST, PPK
reference; provenance in ``data/gnss/README.md``).

Pieces, each with its own track fitted from the reference (`trackmodel.fit.fit_track`,
default tolerances) and the filters started at the piece's first epoch, fed only its epochs:

* ``leg N``: the legs of `trackmodel.polyline.split_legs` (``railnav track fit --leg N``);
* ``leg N part k``: each leg cut at the middle of every street corner tighter than
  `TIGHTEST_TRACK_RADIUS_M` (the smallest tram radii; no railway has such a corner), found
  on the leg's own fitted track;
* ``leg 2 with the U-turn``: leg 2's track with the data from `UTURN_START_SOW` on, the
  issue's held-out case (the car drives leg 2's street backwards, stands, turns round,
  drives it forwards);
* ``leg 2 started in the U-turn``: the same from `UTURN_INSIDE_SOW` on, a start inside the
  turn (the first fix's slow error; stop 39, s39start).

Solutions on each piece: ``gnss-only`` (pseudoranges and Doppler, GPS L1, the run's
defaults: `railnav.navigate`), ``fixes`` (the gnss-only filter on ``[s, v]`` from the SPP
fixes, read back as a fix file, with ``FixModelConfig.correlated_code_errors``; the
speed σ of each fix is the RMS of its velocity σ per axis, as `gnss_obs.fixes` reads an SPP
table; until stop 39 it was the single-point class's 0.1 m/s) and
``spp`` (`gnss_obs.solve_spp`, GPS L1 defaults), all
scored on the same epochs (whole seconds where each has a position and the reference one).
Per piece: epochs, horizontal RMS / max of each, "never worse than SPP" (RMS and max), the
monitor's status counts, the epochs whose along-track error (reference projected on the
piece's track) exceeds 3σ_s, how many of those the monitor left ``ok``, and RMS(e_s/σ_s).

The monitor on these pieces (gnss-only): every epoch it does not call ``ok`` is one of the
first two or one the rejected-row test fails. The GNSS NIS of rows whose variances are
inflated for correlated errors (×8 at 5 m/s, ×40 standing) is a fraction of its degrees
of freedom (its window's tail probability never fell below 0.34), and the fix test's
snapshot carries the same inflated variances (|d| ≤ 1.54 on every piece): neither fails
on real data, and no test sees an error the filter shares with its own rows.

Scoring: the along-track error is the filter's state ``s`` against the reference projected
on the piece's track (``estimates.csv``'s ``s_m`` is clamped to the track: at leg 1 part 2's
start the state was 19.4 m before the track's start, 6.2σ, scored as ~0 before);
``epochs_beyond_track_ends`` counts those epochs. The horizontal figures stay those of the
clamped position (it has none off the track).

With the heading angle Huber-weighted (``NavigatorConfig.track_heading_huber_k``, 4) 49
gnss-only epochs are beyond 3σ_s (57 without), 35 of them ``ok``. Against the reference
and SPP on the same track: on 15 SPP's along-track error is beyond 3σ_s too, the same
sign; on 10 more SPP errs the same way by 1.6-3σ_s with the filter 1-2 m further (leg 1
at 45769-45777 s of week, the stretch whose reference is in question below, and 45981-2,
where the Doppler speed ran 0.2-0.6 m/s low for 10 s: single-point Doppler minus the
reference, summed over 45966-45983, -2.1 m; against the rover's own carrier phase, on the
14 seconds with all three, -1.20 m = Doppler -0.77 m (white noise, no lag) + reference
-0.42 m, ``bench_doppler_carrier.py``); the measurements hold these errors, and no
test of the filter against its own rows sees them. 10 are not SPP's: part 1's last two
(a corner of ~5 m radius), part 6's start, and 7 on the U-turn piece (45988-45993: the car
drives back through leg 2's curve 4-8° off the fitted line for 4 s, δs = δψ/κ taken at
σ_s 0.6-1.0 m while the code-bias state goes to b = 2.1-2.4, i.e. 28-31 m of "slow code
error"; 46005, the end corner). Candidate statistics on those 35 (gnss-only, these
pieces): the heading angle's NIS summed over the monitor's 10-epoch window (χ²₁₀, 1e-3)
would flag 17 of them but also 118 of the 903 epochs within 3σ_s (corners tighter than
the track, the U-turn); the code-bias state against its prior, ``b²/(1 − σ_b²)`` (χ²₁),
flags none at 1e-3 and 6 (the U-turn's) at 2σ with 2 of the 903. Neither is defined on
the simulated runs (no heading rows, no code-bias state there). The monitor is unchanged.
The same 35 one by one, with the rover's own carrier phase as a second reference:
``bench_unflagged.py`` and ``docs/consistency-ablations.md`` ("Stop 35").

The U-turn piece stays worse than SPP in maximum (gnss-only 5.79 m, fixes 4.54 m, SPP
3.82 m): both start at the first fix's slow error (+2.5 / +1.7 m along the track), which
grows by 3.0 m (gnss-only) over the next 17 s, while their code rows, as the calibrated slow
error model says, pull slowly (the worst epochs: e_s 5.5 m at σ_s 1.9 m, 2.8σ; 4.3 m at
2.6 m). Against the carrier (``bench_doppler_filters.py``) those 3.0 m are the filter's
speed short of the carrier's distance by 0.75 m (white Doppler noise, 0.18 m/s RMS a
second), the reference's distance along the track beyond the carrier's by 0.98 m, and
the updates holding ``s`` back by 1.25 m: the Doppler neither lags nor is biased
(``bench_doppler_carrier.py``), and carrier range rates in its place leave the piece at
2.12/4.45 m.

Beside "never worse than SPP" each piece gives what a track-constrained estimate cannot
beat and where each solution's worst epoch comes from (``tests/support/track_offsets.py``):
``reference_offset`` (the reference's horizontal distance from the piece's track, RMS and
max, with the along-track remainder beyond a track end, and its height above the track),
per solution ``along_track_max_m`` and ``at_horizontal_max`` (that epoch's along-track
error and the offset across the track: for a filter the reference's, for SPP its own
cross-track error), SPP's ``along_track_rms_m`` (SPP projected on the track, beyond an end
along the tangent), and per filter ``never_worse_than_spp_along_track`` (along-track RMS
and max against SPP's projection): the horizontal criterion charges SPP its cross-track
error, which a filter on the track does not have, and the filters its state beyond a
track end, which a projected fix does not have. On the U-turn piece the reference is
1.14 m RMS, 2.97 m at most from leg 2's track (every other piece: RMS ≤ 0.28, max ≤ 0.58
m): at 45966-45983 the car drives the street the other way, 0.7-1.9 m beside the fitted
lane (1.1-2.0 m below it to 45977), and at 46012-46017 stands 2.9-3.0 m beside the track's
start; the floor, 2.97 m, is below SPP's 3.82 m. At the worst epochs the along-track error
dominates: gnss-only 45983, 5.79 m = 5.52 along, 1.60 across; fixes 45996, 4.54 m = 4.24
along, 1.76 across; SPP's worst (46030, 3.82 m) is 0.94 along, 3.70 across. Along the
track alone SPP's projection has 2.00/3.50 m RMS/max there (gnss-only 2.08/5.56, fixes
2.65/4.24). ``docs/consistency-ablations.md`` ("Stop 39") splits the two maxima further.

``on_track_code`` (stop 40, `_track_mismatch`): the piece's pseudoranges (the filters'
systems, mask and white σ, no exclusion) solved epoch by epoch on its track for ``s`` and
the clock, against the reference: RMS / largest |error| along the track, split into the
part the reference's offset from the track gives (``mismatch``: the ranges from the
reference solved on the track) and the code errors' part (``code``); each worst epoch
(``at_horizontal_max``) gets the same three there (``rows_on_track``), and each filter
``never_worse_than_on_track_code`` (its along-track RMS and max against that solution's:
what the filter's own position rows say without memory, the fair bar for a filter with
no along-track sensor besides them). On the U-turn piece the rows on the track are
3.04 / 6.68 m (mismatch 0.69 / 1.66, code 2.87 / 6.58) against gnss-only 1.86 / 5.10,
fixes 2.66 / 4.24 and SPP's projection 2.00 / 3.50; on every other piece the mismatch is
≤ 0.16 m RMS, and the code part on the track exceeds SPP's projection on 8 of the 10
pieces (leg 1 2.82 against 2.36 m RMS): what SPP puts into its height and across the
track goes along it when both are held (the same rows with a free height come 4.9-10.4 m
below the track on average per piece; their along-track error then falls only a little,
3.03 → 2.79 m RMS on the U-turn piece, docs/consistency-ablations.md, "Stop 40").
The along-track errors are taken against the reference's ``s`` run on beyond a track end
(`tests.support.track_offsets.along_track_s`), as the filters' state and SPP's
projection are (a clamped reference moved these figures by ≤ 6 mm).

Before the heading's weight and this scoring (main 9ee4652's analysis): the 53 gnss-only
epochs beyond 3σ_s (of 952; main 008931e), one by one against the
reference and SPP projected on the same track: 20 are a slow code error that SPP shares
(its along-track error beyond 3σ_s too, same sign: 13 on leg 1 at 672-800 m, where
the filter's σ_s, 0.3 m out of a tight corner, had grown to 0.5-1.3 m, 6 on leg 1 and
part 6 at 1750 m and 420-446 m, 1 at leg 1's 5-m corner); 15 are that error with the filter
1-2 m further off than SPP (leg 1 at 770-850 m, after its speed lagged the car's
acceleration by 1 m/s for 3 s at σ_v 0.15-0.25 m/s, 2.3 m lost; and the same places on
parts 3 and 6); 2 are part 6's start (3.4 m against
SPP's 2.0 at σ_s 0.74); 2 are part 1's last epochs, in a corner of ~5 m radius (0.9 m at
σ_s 0.28, drawn from the Doppler rows through the curvature); 14 are the U-turn piece,
where SPP errs the other way (the car drives back 1.2-2 m across the fitted track, then
stands 3 m beside its end: the filter's ``s`` and code-bias state split the rows'
apparent position wrongly through the heading rows). A snapshot test with the rows'
white variances (``R`` over the filter's inflation) against the prior's apparent
variance flags none of the 53 at 3.29σ (and 1 of the 899 others): the apparent position
``s + σ_e b`` agrees with the rows; the error is in the split, which only an independent
``s`` (odometer, balise) could test. ``--heading-correlation-m`` measures the heading
rows' part.
The reference itself is in question on 22 of the 53 (leg 1 and part 3, seconds of week
45745-45772): in the second to 45745 it moves 6.11 m horizontally and 1.73 m down while
the single-point Doppler speed is 3.92 m/s and the filter's 4.05 (over the drive's 460
seconds with both, reference displacement and single-point Doppler speed differ by
0.23 m/s RMS; this is the largest difference), and it has no solution for 45747-45750.
The rover's own L1 carrier phases (GPS and Galileo, five satellites, time-differenced over
that second, residual 6 mm RMS; the same differences match the reference's displacement
to 7 cm median over 435 seconds) give 4.17 m horizontally and 0.03 m down.
Were the 2.1 m step the reference's, the 22 would be within 3σ_s (31 of 53 left); with
the heading correlated over 20 m, 46 of its 48 epochs beyond 3σ_s are in that stretch
(3 left). Nothing here corrects the reference: which side of the step is right is not
known.

Calibration and held-out: the real-data error model (`railnav.filters.code_bias`, the
heading's σ) was calibrated on `CALIBRATION_PIECES`, the drive's first ~3 minutes
(`bench_code_bias.py`); ``groups`` sums the figures over those pieces (``calibration``),
over the other parts and leg 2's two pieces (``held_out``), and gives ``leg 1`` (both) apart.

``--urban-sigmas``: the two filters with the ``additive`` pseudorange σ model calibrated on
this drive (`gnss_obs.measurements.URBAN_CODE_SIGMAS`), SPP with its own (the default);
``benchmarks/results/real_pieces_urban_sigmas.json``. ``--heading-curvature-m D``: the
filters with ``NavigatorConfig.track_heading_curvature_m`` = D (calibrated 2.2 m, off by
default); ``benchmarks/results/real_pieces_heading_curvature.json``.
``--heading-correlation-m D``: the filters with
``NavigatorConfig.track_heading_correlation_m`` = D (off by default; the figures of
D = 3, 5, 7, 10 m are in that field's docstring).

Writes ``benchmarks/results/real_pieces.json``. Run: ``python benchmarks/bench_real_pieces.py
--data DIR`` (a few minutes).
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
if str(Path(__file__).resolve().parents[1]) not in sys.path:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests.support
from _data_dir import add_data_argument, checked_data_dir, read_drive  # noqa: E402
from _track_mismatch import on_track_code_errors, on_track_summary, rows_at_worst  # noqa: E402

from ekf.packing import diagonal_indices  # noqa: E402
from gnss_obs.fixes.read import read_fixes  # noqa: E402
from gnss_obs.measurements import URBAN_CODE_SIGMAS, MeasurementConfig  # noqa: E402
from gnss_obs.spp import SppConfig, solve_spp  # noqa: E402
from railnav.config import NavigatorConfig  # noqa: E402
from railnav.filters.gnss_only_model import CODE_BIAS_STATE  # noqa: E402
from railnav.evaluation.spp_accuracy import spp_errors  # noqa: E402
from railnav.navigation.navigator import navigate  # noqa: E402
from railnav.sensor_data import SensorData  # noqa: E402
from tests.support.track_offsets import (  # noqa: E402
    along_track_s,
    largest_error_parts,
    offset_summary,
    reference_offsets,
)
from trackmodel.files import atomic_write_text  # noqa: E402
from trackmodel.fit import fit_track  # noqa: E402
from trackmodel.polyline import Polyline, split_legs  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "real_pieces.json"
DATA_FILES = ("rover_obs.rnx", "broadcast_nav.rnx", "reference_trajectory.csv")
#: Corners tighter than this radius split a leg (tram minimum radii are ~18-25 m), m.
TIGHTEST_TRACK_RADIUS_M = 20.0
#: A piece needs this many reference points (fit and statistics), and corners closer
#: than `MIN_PIECE_M` to a piece end do not split it.
MIN_PIECE_POINTS = 20
MIN_PIECE_M = 60.0
#: GPS week and the seconds of week where the issue's held-out run starts.
GPS_WEEK = 2134
UTURN_START_SOW = 45966.0
#: Seconds of week inside the U-turn (between leg 1 and leg 2): a start there (s39uturn).
UTURN_INSIDE_SOW = 46006.0
WEEK_S = 604_800
SAMPLE_STEP_M = 1.0
#: The pieces the real-data error model was calibrated on (`bench_code_bias.py`).
CALIBRATION_PIECES = ("leg 1 part 1", "leg 1 part 2", "leg 1 part 3")


def _corner_cuts(track) -> list[float]:
    """``s`` of the middle of each corner tighter than `TIGHTEST_TRACK_RADIUS_M`."""
    s = np.arange(0.0, track.length_m, SAMPLE_STEP_M)
    tight = np.abs(track.at(s).curvature_1pm) > 1.0 / TIGHTEST_TRACK_RADIUS_M
    cuts, start = [], None
    for k, flag in enumerate(np.append(tight, False)):
        if flag and start is None:
            start = k
        elif not flag and start is not None:
            mid = 0.5 * (s[start] + s[k - 1])
            if MIN_PIECE_M <= mid <= track.length_m - MIN_PIECE_M:
                cuts.append(float(mid))
            start = None
    return cuts


def pieces(reference: pd.DataFrame) -> list[dict]:
    """The pieces of the module docstring: name, reference rows, track."""
    poly = Polyline(np.radians(reference["lat_deg"].to_numpy()),
                    np.radians(reference["lon_deg"].to_numpy()), reference["h_m"].to_numpy())
    out = []
    for n, index in enumerate(split_legs(poly), start=1):
        leg = fit_track(poly.lat[index], poly.lon[index], poly.h[index]).track
        out.append({"name": f"leg {n}", "rows": index, "track": leg})
        s = leg.project(poly.lat[index], poly.lon[index]).s
        bounds = [-np.inf, *_corner_cuts(leg), np.inf]
        if len(bounds) > 2:
            for k in range(len(bounds) - 1):
                part = index[(s >= bounds[k]) & (s < bounds[k + 1])]
                if part.size >= MIN_PIECE_POINTS:
                    track = fit_track(poly.lat[part], poly.lon[part], poly.h[part]).track
                    out.append({"name": f"leg {n} part {k + 1}", "rows": part, "track": track})
        if n == 2:
            sow = reference["gps_time_s"].to_numpy() - GPS_WEEK * WEEK_S
            out.append({"name": "leg 2 with the U-turn", "track": leg,
                        "rows": np.flatnonzero(sow >= UTURN_START_SOW)})
            out.append({"name": "leg 2 started in the U-turn", "track": leg,
                        "rows": np.flatnonzero(sow >= UTURN_INSIDE_SOW)})
    return out


def _at_epochs(estimates: pd.DataFrame) -> pd.DataFrame:
    t = estimates["gps_time_s"].to_numpy()
    out = estimates[np.abs(t - np.round(t)) < 1e-3].copy()
    out["gps_time_s"] = np.round(out["gps_time_s"])
    return out.drop_duplicates("gps_time_s", keep="last")


def _state_columns(result) -> dict:
    """``s_state_m`` (the state's s as it is: estimates.csv clamps s_m to [0, length], its
    position is on the track, which hides a filter beyond a piece's start as an error of
    ~0) and, where the run has the code-bias state, ``code_bias`` and its σ."""
    names = result.layout.names
    out = {"s_state_m": result.x[:, names.index("s")]}
    if CODE_BIAS_STATE in names:
        i = names.index(CODE_BIAS_STATE)
        variance = result.P[:, diagonal_indices(len(names))[i]]      # P is packed
        out.update(code_bias=result.x[:, i], sigma_code_bias=np.sqrt(variance))
    return out


def solve_piece(piece: dict, obs, nav, reference: pd.DataFrame, spp: pd.DataFrame,
                workdir: Path, config: NavigatorConfig) -> tuple[dict, dict, tuple]:
    """The three solutions on one piece (module docstring), unscored: ``solutions``
    (``spp``, ``gnss-only``, ``fixes``: frames at whole seconds, the filters' with the
    unclamped state ``s_state_m``), the two filters' `railnav.NavigationResult` s, and the
    piece's ``(t0, t1)`` GPS seconds."""
    times = reference["gps_time_s"].to_numpy()[piece["rows"]]
    t0, t1 = float(times[0]), float(times[-1])
    table = obs.table
    piece_obs = replace(obs, table=table[(table["gps_time_s"] >= t0 - 1e-6)
                                         & (table["gps_time_s"] <= t1 + 1e-6)])
    spp_piece = spp[(spp["gps_time_s"] >= t0 - 1e-6) & (spp["gps_time_s"] <= t1 + 1e-6)]
    fix_path = workdir / f"{piece['name'].replace(' ', '_')}_fixes.csv"
    spp_piece.to_csv(fix_path, index=False)
    track = piece["track"]
    solutions, monitor = {"spp": spp_piece}, {}
    for name, data in (("gnss-only", SensorData(start_gps_time_s=t0, obs=piece_obs, nav=nav)),
                       ("fixes", SensorData(start_gps_time_s=t0, fixes=read_fixes(fix_path)))):
        result = navigate(track, data, config)
        solutions[name] = _at_epochs(result.estimates.assign(**_state_columns(result)))
        monitor[name] = result
    return solutions, monitor, (t0, t1)


def run_piece(piece: dict, obs, nav, reference: pd.DataFrame, spp: pd.DataFrame,
              workdir: Path, config: NavigatorConfig = NavigatorConfig(filter="gnss-only")
              ) -> dict:
    """The three solutions on one piece, scored (module docstring)."""
    solutions, monitor, (t0, t1) = solve_piece(piece, obs, nav, reference, spp, workdir,
                                               config)
    track = piece["track"]
    errors = {k: spp_errors(v, reference) for k, v in solutions.items()}
    common = None
    for e in errors.values():
        t = set(e.loc[np.isfinite(e["horizontal_m"]), "gps_time_s"].round())
        common = t if common is None else common & t
    common = np.array(sorted(common))
    row = {"epochs": int(common.size), "gps_time_s": [t0, t1],
           "track_length_m": float(track.length_m)}
    ref = reference.set_index(np.round(reference["gps_time_s"]))
    r = ref.loc[common]
    offsets = reference_offsets(track, r["lat_deg"], r["lon_deg"], r["h_m"])
    row["reference_offset"] = offset_summary(offsets)
    rows_on_track = on_track_code_errors(obs, nav, config, track, r.reset_index(drop=True),
                                         offsets["s_m"].to_numpy())
    row["on_track_code"] = on_track_summary(rows_on_track)
    s_ref = along_track_s(track, r["lat_deg"], r["lon_deg"])   # beyond an end: not clamped
    for name, e in errors.items():
        h = e.set_index(np.round(e["gps_time_s"])).loc[common, "horizontal_m"].to_numpy()
        row[name] = {"horizontal_rms_m": float(np.sqrt(np.mean(h ** 2))),
                     "horizontal_max_m": float(h.max())}
        row[name].update(_largest_parts(name, solutions[name], common, h, offsets, s_ref,
                                        track))
    for name in ("gnss-only", "fixes"):
        est = solutions[name].set_index("gps_time_s").loc[common]
        e_s = est["s_state_m"].to_numpy() - s_ref
        z = e_s / est["sigma_s_m"].to_numpy()
        beyond = np.abs(z) > 3.0
        status = est["status"].to_numpy()
        mon = monitor[name].statistics()["monitor"]
        row[name].update(
            never_worse_than_spp=bool(row[name]["horizontal_rms_m"] <= row["spp"]["horizontal_rms_m"]
                                      and row[name]["horizontal_max_m"]
                                      <= row["spp"]["horizontal_max_m"]),
            status_epochs=mon["epochs"], recoveries=mon["recoveries"],
            final_status=mon["final_status"], epochs_beyond_3sigma=int(beyond.sum()),
            epochs_beyond_3sigma_not_flagged=int((beyond & (status == "ok")).sum()),
            epochs_beyond_track_ends=int(np.count_nonzero(
                est["s_state_m"].to_numpy() != est["s_m"].to_numpy())),
            along_track_rms_m=float(np.sqrt(np.mean(e_s ** 2))),
            along_track_rms_sigma=float(np.sqrt(np.mean(z ** 2))))
        row[name]["never_worse_than_spp_along_track"] = bool(
            row[name]["along_track_rms_m"] <= row["spp"]["along_track_rms_m"]
            and row[name]["along_track_max_m"] <= row["spp"]["along_track_max_m"])
        row[name]["never_worse_than_on_track_code"] = bool(
            row[name]["along_track_rms_m"] <= row["on_track_code"]["along_track_rms_m"]
            and row[name]["along_track_max_m"] <= row["on_track_code"]["along_track_max_m"])
    rows_at_worst(row, rows_on_track)
    return row


def _largest_parts(name: str, solution: pd.DataFrame, common, horizontal: np.ndarray,
                   offsets: pd.DataFrame, s_ref: np.ndarray, track) -> dict:
    """A solution's along-track error on the piece's track (the filters' state ``s``; SPP
    projected on the track) and its worst horizontal epoch split
    (`tests.support.track_offsets.largest_error_parts`): for the filters, whose position is
    on the track, the offset is the reference's from the track; for SPP its own cross-track
    error. SPP also gets its along-track RMS (the filters' is ``along_track_rms_m``)."""
    est = solution.assign(gps_time_s=np.round(solution["gps_time_s"])).drop_duplicates(
        "gps_time_s", keep="last").set_index("gps_time_s").loc[common]
    cross_ref = offsets["cross_track_m"].to_numpy()
    if name == "spp":
        proj = track.project(np.radians(est["lat_deg"].to_numpy()),
                             np.radians(est["lon_deg"].to_numpy()))
        # beyond a track end the fix's s runs on along the tangent, as the filters' state
        along, offset = proj.s + proj.along_m - s_ref, proj.cross_track_m - cross_ref
    else:
        along, offset = est["s_state_m"].to_numpy() - s_ref, cross_ref
    out = largest_error_parts(np.asarray(common, float), horizontal, along, offset)
    if name == "spp":
        out["along_track_rms_m"] = float(np.sqrt(np.mean(along ** 2)))
    return out


def load_drive(data: Path):
    """The drive's rover observations, navigation, reference and GPS L1 SPP fixes (the
    epochs with a position) from the folder `data`."""
    obs, nav, reference = read_drive(data)
    spp = solve_spp(obs, nav, SppConfig(measurement=MeasurementConfig(systems="G"))).to_frame()
    return obs, nav, reference, spp[np.isfinite(spp["lat_deg"])]


def group_totals(results: dict) -> dict:
    """Per group (``calibration``, ``held_out``, ``leg 1``) and filter: the epochs, those
    beyond 3σ_s and those the monitor left ``ok``, and the pieces worse than SPP
    (horizontally, and along the track); the start inside the U-turn (the U-turn piece's
    epochs again) is in none."""
    apart = (*CALIBRATION_PIECES, "leg 1", "leg 2 started in the U-turn")
    groups = {"calibration": [n for n in results if n in CALIBRATION_PIECES],
              "held_out": [n for n in results if n not in apart],
              "leg 1": [n for n in results if n == "leg 1"]}
    out = {}
    for group, names in groups.items():
        out[group] = {"pieces": names}
        for k in ("gnss-only", "fixes"):
            rows = [results[n][k] for n in names]
            out[group][k] = {
                "epochs": int(sum(results[n]["epochs"] for n in names)),
                "epochs_beyond_3sigma": int(sum(r["epochs_beyond_3sigma"] for r in rows)),
                "epochs_beyond_3sigma_not_flagged": int(sum(
                    r["epochs_beyond_3sigma_not_flagged"] for r in rows)),
                "pieces_worse_than_spp": [n for n, r in zip(names, rows)
                                          if not r["never_worse_than_spp"]],
                "pieces_worse_than_spp_along_track": [
                    n for n, r in zip(names, rows) if not r["never_worse_than_spp_along_track"]],
                "pieces_worse_than_on_track_code": [
                    n for n, r in zip(names, rows) if not r["never_worse_than_on_track_code"]]}
    return out


def bench_config(*, recover: bool = True) -> NavigatorConfig:
    """The filters' configuration here: the run's defaults (gnss-only), the monitor's
    recovery as asked, and the SPP fixes' errors correlated as their pseudoranges'."""
    config = NavigatorConfig(filter="gnss-only")
    # recovery is on by default (MonitorConfig.recover); --no-recovery turns it off here
    return replace(config, monitor=replace(config.monitor, recover=recover),
                   fix_model=replace(config.fix_model, correlated_code_errors=True))


def run_pieces(obs, nav, reference: pd.DataFrame, spp: pd.DataFrame,
               config: NavigatorConfig) -> dict:
    """`run_piece` on every piece of `pieces`, each printed as it ends."""
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for piece in pieces(reference):
            results[piece["name"]] = r = run_piece(piece, obs, nav, reference, spp,
                                                   Path(tmp), config)
            g, f, s = r["gnss-only"], r["fixes"], r["spp"]
            print(f"{piece['name']}: {r['epochs']} epochs; horizontal RMS/max gnss-only "
                  f"{g['horizontal_rms_m']:.2f}/{g['horizontal_max_m']:.2f}"
                  f", fixes {f['horizontal_rms_m']:.2f}/{f['horizontal_max_m']:.2f}"
                  f", SPP {s['horizontal_rms_m']:.2f}/{s['horizontal_max_m']:.2f} m; "
                  f">3σ not flagged {g['epochs_beyond_3sigma_not_flagged']}/"
                  f"{g['epochs_beyond_3sigma']}, {f['epochs_beyond_3sigma_not_flagged']}/"
                  f"{f['epochs_beyond_3sigma']}", flush=True)
    return results


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_data_argument(parser, DATA_FILES)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--no-recovery", action="store_true",
                        help="the monitor flags but never changes the state (the baseline)")
    parser.add_argument("--heading-curvature-m", type=float, default=None,
                        help="NavigatorConfig.track_heading_curvature_m of the filters "
                             "(default: the configuration's, 0)")
    parser.add_argument("--heading-correlation-m", type=float, default=None,
                        help="NavigatorConfig.track_heading_correlation_m of the filters "
                             "(default: the configuration's, 0)")
    parser.add_argument("--urban-sigmas", action="store_true",
                        help="the filters use the additive pseudorange σ model "
                             "(gnss_obs.measurements.URBAN_CODE_SIGMAS); SPP keeps its own")
    args = parser.parse_args(argv)
    config = bench_config(recover=not args.no_recovery)
    if args.urban_sigmas:
        config = replace(config, measurement=replace(config.measurement, **URBAN_CODE_SIGMAS))
    if args.heading_curvature_m is not None:
        config = replace(config, track_heading_curvature_m=args.heading_curvature_m)
    if args.heading_correlation_m is not None:
        config = replace(config, track_heading_correlation_m=args.heading_correlation_m)
    data = checked_data_dir(parser, args.data, DATA_FILES)
    started = time.perf_counter()
    obs, nav, reference, spp = load_drive(data)
    results = run_pieces(obs, nav, reference, spp, config)
    out = {"data": "gnss_urban_drive", "tightest_track_radius_m": TIGHTEST_TRACK_RADIUS_M,
           "recovery": not args.no_recovery,
           "track_heading_curvature_m": config.track_heading_curvature_m,
           "track_heading_correlation_m": config.track_heading_correlation_m,
           "code_bias": {"sigma": config.code_bias.sigma, "time_s": config.code_bias.time_s},
           "groups": group_totals(results),
           **({"filters_measurement_sigmas": URBAN_CODE_SIGMAS} if args.urban_sigmas else {}),
           "pieces": results,
           "all_never_worse_than_spp": all(r[k]["never_worse_than_spp"] for r in results.values()
                                           for k in ("gnss-only", "fixes")),
           "all_never_worse_than_spp_along_track": all(
               r[k]["never_worse_than_spp_along_track"] for r in results.values()
               for k in ("gnss-only", "fixes")),
           "all_never_worse_than_on_track_code": all(
               r[k]["never_worse_than_on_track_code"] for r in results.values()
               for k in ("gnss-only", "fixes")),
           "epochs_beyond_3sigma_not_flagged": sum(
               r[k]["epochs_beyond_3sigma_not_flagged"] for r in results.values()
               for k in ("gnss-only", "fixes")),
           "seconds": time.perf_counter() - started, "machine": platform.platform()}
    for group, g in out["groups"].items():
        print(f"{group}: " + "; ".join(
            f"{k} beyond 3σ {g[k]['epochs_beyond_3sigma']} (not flagged "
            f"{g[k]['epochs_beyond_3sigma_not_flagged']}) of {g[k]['epochs']}, worse than SPP "
            f"{len(g[k]['pieces_worse_than_spp'])}" for k in ("gnss-only", "fixes")))
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    print(f"{args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
