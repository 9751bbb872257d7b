"""What ``railnav run`` prints when it is done: what ran and the headline errors."""
from __future__ import annotations

from pathlib import Path

__all__ = ["report", "monitor_lines", "fix_hint_lines", "receiver_hint_lines",
           "noise_scale_lines"]

#: Share of the monitor's epochs not ``ok`` above which a gnss-only run on fixes taken as
#: white gets the `fix_hint_lines` hint.
HINT_NOT_OK_SHARE = 0.5

#: Share of the GNSS rows rejected (gate and fault screen) above which a file run whose
#: receiver σ were not given gets the `receiver_hint_lines` hint. Rows whose σ are right
#: are rejected far less: 0.3 % on the urban drive's excerpt (gnss-only, G and GE), 0.3-1.3 %
#: of simulated 300-s trips told the simulated σ (curvy tactical and MEMS, paper2017); the
#: same trips on the default (a real receiver's) σ: 38-50 % (e7d615c, before the fault
#: screen tested correlated rows at their own variance; a 1000-s curvy trip after: 52 %).
HINT_REJECTED_SHARE = 0.05

#: A factor on the GNSS σ (`railnav.filters.noise_scale`) above which the run report says
#: so (`noise_scale_lines`).
REPORT_SCALE = 1.5


def monitor_lines(mon: dict | None, recoveries: str = "recoveries") -> list[str]:
    """The divergence monitor's status counts (``summary.json`` ``statistics.monitor``),
    and a warning when the run ended ``lost`` (issue 14: it exits 0 but says so)."""
    if not mon:
        return []
    e = mon["epochs"]
    lines = [f"  monitor: {e['ok']} ok, {e['degraded']} degraded, {e['lost']} lost epochs; "
             f"{mon['recoveries']} {recoveries}"]
    if mon["final_status"] == "lost":
        lines.append("  LOST at the end of the run: the last estimates are not to be "
                     "trusted (monitor status 'lost', estimates.csv 'status')")
    return lines


def fix_hint_lines(summary: dict) -> list[str]:
    """A hint for a gnss-only run on fixes taken as white (``--correlated-fix-errors`` not
    given) whose monitor found most epochs not ``ok``: a receiver's single-point fixes
    have correlated errors (the urban drive's SPP fixes: every epoch ``degraded``, NEES
    4.7 for one state; with the flag 178 of 180 ``ok``)."""
    mon = summary["statistics"].get("monitor")
    if summary["filter"] != "gnss-only" or "fix_epochs" not in summary["statistics"] \
            or not mon:
        return []
    e = mon["epochs"]
    if e["degraded"] + e["lost"] <= HINT_NOT_OK_SHARE * sum(e.values()):
        return []
    return ["  hint: if the fixes are a receiver's single-point or DGPS solutions, their "
            "errors are correlated from epoch to epoch: --correlated-fix-errors"]


def noise_scale_lines(summary: dict) -> list[str]:
    """A line when the adaptive noise scale (`railnav.filters.noise_scale`,
    ``summary.json``'s ``statistics.noise_scale``) rose above `REPORT_SCALE` for a row
    kind: the receiver's σ looked that many times too small."""
    scale = summary["statistics"].get("noise_scale") or {}
    big = [(kind.replace("_", " "), v["max"]) for kind, v in scale.items()
           if v["max"] > REPORT_SCALE]
    if not big:
        return []
    factors = ", ".join(f"{kind} up to {k:.1f}×" for kind, k in big)
    return [f"  the receiver's σ looked too small ({factors}; innovations.csv noise_scale): "
            "the filter scaled them up; tell railnav with --sigma-pr-m and --sigma-rr-mps"]


def receiver_hint_lines(summary: dict) -> list[str]:
    """A hint for a run on GNSS observations whose receiver σ were not given and whose
    gate and fault screen rejected more than `HINT_REJECTED_SHARE` of the rows: the
    receiver is noisier than the default σ say, and the filter trusts its rows too much
    (a simulated 1000-s curvy trip as plain files without the noise scale: 52 % rejected,
    NEES 17 for 5 states, 40 restarts; told the simulated σ, 0.08 % rejected and NEES
    4.1). None when `noise_scale_lines` has said so already (with the scale, that trip:
    σ factors 2.7 / 10.4, 3.3 % rejected, NEES 6.0, no restart)."""
    if noise_scale_lines(summary):
        return []
    stats = summary["statistics"]
    rows, rejected = stats.get("gnss_rows") or 0, stats.get("gnss_rows_rejected") or 0
    if rows == 0 or rejected <= HINT_REJECTED_SHARE * rows:
        return []
    return [f"  hint: {rejected} of {rows} GNSS rows ({100 * rejected / rows:.0f} %) were "
            "rejected: the receiver is noisier than the σ the filter assumes; give its "
            "--sigma-pr-m and --sigma-rr-mps"]


def report(outcome, out: Path) -> str:
    """A few lines for the terminal: what ran and the headline errors."""
    s = outcome.summary
    lines = [f"{s['filter']} filter: {s['steps']} steps, {_epochs(outcome)} in "
             f"{s['runtime_s']:.2f} s -> {out}/"]
    left = s.get("left_track")
    if left:
        lines.append(f"  stopped at t={left['time_s']:.1f} s: s = {left['s_m']:.1f} m is beyond "
                     f"the track's {left['end']} ({left['track_length_m']:.1f} m); later data "
                     "not used")
    stats = s["statistics"]
    lines.extend(monitor_lines(stats.get("monitor")))
    lines.extend(noise_scale_lines(s))
    if "fix_epochs" in stats:
        lines.append(f"  {stats['fix_epochs']} GNSS fixes, {stats['fixes_rejected']} rejected "
                     "by the fault screen")
    ref = s.get("reference")
    if ref and ref.get("source") == "fixes":
        lines.append(f"  reference: {ref['kept']} of {ref['candidates']} {ref['quality']} "
                     f"fixes ({ref['off_track']} off the track, {ref['jumps']} jumps); "
                     f"{ref['estimates_compared']} estimates compared")
    errors = s.get("errors")
    if errors and errors["all"]["along_track_m"]["rms"] is None:
        lines.append("  no reference: no estimate has a reference sample (no errors.csv)")
    elif errors:
        a = errors["all"]
        lines.append(f"  along-track RMS {a['along_track_m']['rms']:.3f} m, max "
                     f"{a['along_track_m']['max']:.3f} m; speed RMS "
                     f"{_number(a['speed_mps']['rms'], '.4f')} m/s; NEES mean "
                     f"{_number(errors['nees']['mean'], '.2f')} (dof {errors['nees']['dof']})")
        for o in errors["outages"]:
            lines.append(f"  outage {o['start_s']:g}+{o['duration_s']:g} s: along-track error "
                         f"at its end {_number(o['at_end']['along_track_m'], '+.3f')} m")
    smoothed = (s.get("smoothed") or {}).get("errors")
    if smoothed and smoothed["all"]["along_track_m"]["rms"] is None:
        lines.append("  smoothed (RTS): no reference (no smoothed_errors.csv)")
    elif smoothed:
        a = smoothed["all"]
        lines.append(f"  smoothed (RTS): along-track RMS {_number(a['along_track_m']['rms'], '.3f')}"
                     f" m, max {_number(a['along_track_m']['max'], '.3f')} m; speed RMS "
                     f"{_number(a['speed_mps']['rms'], '.4f')} m/s; NEES mean "
                     f"{_number(smoothed['nees']['mean'], '.2f')} (dof {smoothed['nees']['dof']})")
    baro = s.get("baro")
    if baro:
        lines.append(f"  baro bias {baro['bias_m']:+.2f} ± {baro['sigma_bias_m']:.2f} m "
                     f"({baro['bias_flagged']} of {baro['readings']} readings flagged); "
                     f"{baro['gnss_heights_flagged']} of {baro['gnss_heights_checked']} GNSS "
                     "heights disagree")
    return "\n".join(lines)


def _epochs(outcome) -> str:
    """The run's measurement epochs: ``N GNSS epochs``; with odometer or balise rows (whose
    epochs are measurement epochs too, ``summary.json`` ``gnss_epochs`` counts them all),
    how many have a row of each kind (an epoch can have several)."""
    stats = outcome.summary["statistics"]
    if "odometer" not in stats and "balises" not in stats:
        return f"{stats['gnss_epochs']} GNSS epochs"
    from railnav.filters.balise_rows import BALISE_ROW_KIND   # CasADi: after the run only
    from railnav.filters.odometer_rows import ODOMETER_ROW_KINDS
    inn = outcome.result.innovations
    kinds = {"GNSS": ~inn["kind"].isin([*ODOMETER_ROW_KINDS, BALISE_ROW_KIND]),
             "odometer": inn["kind"].isin(ODOMETER_ROW_KINDS),
             "balise": inn["kind"] == BALISE_ROW_KIND}
    counts = ", ".join(f"{inn.loc[rows, 'epoch'].nunique()} {name}"
                       for name, rows in kinds.items())
    return f"{stats['gnss_epochs']} measurement epochs ({counts})"


def _number(value, fmt: str) -> str:
    """`value` formatted, or ``n/a`` for None (a quantity the reference does not know)."""
    return "n/a" if value is None else format(value, fmt)
