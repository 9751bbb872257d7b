"""Simulated satellite faults against the fault detection and exclusion: detection figures.

A fault case is a simulated trip with `gnss_obs.SatelliteFault` s, run twice with the same
seed, with and without the faults (the faults add deterministic errors, so both runs see
the same noise). `fault_case` measures, from the faulted run's ``innovations.csv``
(`railnav.navigation.result`) and the two runs' errors:

* **detection**: the faulty rows (the fault's satellite and kind inside its window) whose
  injected error is at least `DETECTABLE_SIGMA` σ of their innovation, and the share of
  them not used (rejected or excluded); the delay from the fault's start to the channel's
  first rejection and to its exclusion;
* **false alarms**: the share of fault-free rows not used, leaving out the faulty
  channels' rows after their fault ended until they are used again (reported as the
  **re-admission delay**: fault end to the channel's first used row);
* **pull**: the largest change of the along-track error caused by the faults, ``|e_fault −
  e_clean|``, in units of the filter's own σ_s, inside the fault windows (the issue's
  "not more than 3σ"); the largest ``|e_fault|/σ_s`` is reported too;
* **clock jump**: the time and size of each declared receiver clock jump.

`clock_jump_faults` writes a receiver clock step as the simulator's faults: the same step
on every satellite's pseudorange and nothing on the Doppler, which is what a clock step
does to the observations.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from gnss_obs.sim_events import SatelliteFault
from railnav.config import DEFAULT_SYSTEMS
from railnav.jobs.run import RunOutcome, run_simulated

__all__ = ["clock_jump_faults", "fault_case", "FaultCaseResult", "faulty_rows",
           "DETECTABLE_SIGMA"]

Array = npt.NDArray[np.float64]

#: Faulty rows whose injected error is at least this many σ of their innovation count in
#: the detection rate (a ramp's first seconds are not detectable by any test).
DETECTABLE_SIGMA = 3.0


def clock_jump_faults(satellites, start_s: float, jump_m: float, *,
                      duration_s: float = math.inf) -> tuple[SatelliteFault, ...]:
    """A receiver clock step of `jump_m` (m) at `start_s` (s), as satellite faults.

    Parameters
    ----------
    satellites : iterable of str
        Every satellite that may be observed (e.g. ``G01``…``G32``).
    start_s : float
        s from the trip start.
    jump_m : float
        The step ``c Δt`` on every pseudorange, m.
    duration_s : float
        How long the step lasts (inf: a permanent clock jump).
    """
    return tuple(SatelliteFault(sv, start_s, duration_s, step_m=jump_m) for sv in satellites)


def faulty_rows(innovations: pd.DataFrame, faults) -> tuple[npt.NDArray[np.bool_], Array]:
    """Which rows of an ``innovations.csv`` table carry a fault, and the injected error.

    Parameters
    ----------
    innovations : pandas.DataFrame
        ``time_s, sv, kind`` per row.
    faults : sequence of gnss_obs.SatelliteFault

    Returns
    -------
    faulty : ndarray of bool, shape (rows,)
    error : ndarray, shape (rows,)
        Injected pseudorange (m) or range-rate (m/s) error of each row.
    """
    t = innovations["time_s"].to_numpy()
    sv = innovations["sv"].to_numpy()
    kind = innovations["kind"].to_numpy()
    error = np.zeros(t.size)
    faulty = np.zeros(t.size, dtype=bool)
    for f in faults:
        on = (sv == f.sv) & (t >= f.start_s) & (t < f.start_s + f.duration_s)
        pr = on & (kind == "pseudorange")
        error[pr] += f.step_m + f.ramp_mps * (t[pr] - f.start_s)
        faulty |= pr
        if f.affects_doppler and f.ramp_mps != 0.0:
            rr = on & (kind == "range_rate")
            error[rr] += f.ramp_mps
            faulty |= rr
    return faulty, error


@dataclass(frozen=True, eq=False)
class FaultCaseResult:
    """Figures of one fault case (module docstring).

    Attributes
    ----------
    name : str
    detection_rate : float
        Share of the detectable faulty rows not used (NaN without any).
    detectable_rows : int
    false_alarm_rate : float
        Share of the fault-free rows not used.
    fault_free_rows : int
    time_to_detect_s, time_to_exclude_s : float
        From the earliest fault's start to the first rejection (or exclusion) of a faulty
        row, s (NaN: never).
    readmission_delay_s : float
        Longest delay from a fault's end to its channel's next used row, s (NaN: the
        fault lasts to the end of the data).
    pull_sigma : float
        Largest ``|e_fault − e_clean| / σ_s`` of the along-track error inside the fault
        windows.
    max_error_sigma : float
        Largest ``|e_fault| / σ_s`` there.
    clock_jumps : list of dict
        ``time_s, jump_m`` of each declared receiver clock jump.
    faulted, clean : RunOutcome
    """

    name: str
    detection_rate: float
    detectable_rows: int
    false_alarm_rate: float
    fault_free_rows: int
    time_to_detect_s: float
    time_to_exclude_s: float
    readmission_delay_s: float
    pull_sigma: float
    max_error_sigma: float
    clock_jumps: list
    faulted: RunOutcome
    clean: RunOutcome

    def row(self) -> dict:
        """The figures as one table row (no run objects)."""
        return {"case": self.name, "detection_rate": self.detection_rate,
                "detectable_rows": self.detectable_rows,
                "false_alarm_rate": self.false_alarm_rate,
                "time_to_detect_s": self.time_to_detect_s,
                "time_to_exclude_s": self.time_to_exclude_s,
                "readmission_delay_s": self.readmission_delay_s, "pull_sigma": self.pull_sigma,
                "max_error_sigma": self.max_error_sigma,
                "clock_jumps": len(self.clock_jumps)}


def fault_case(track, scenario, faults, *, name: str = "fault", seed: int = 0, config=None,
               clean: RunOutcome | None = None, systems: str = DEFAULT_SYSTEMS) -> FaultCaseResult:
    """Run a scenario with and without `faults` and measure the fault handling.

    Parameters
    ----------
    track : trackmodel.Track
    scenario : railnav.Scenario
    faults : sequence of gnss_obs.SatelliteFault
        Times from the trip start.
    name : str
    seed : int
    config : NavigatorConfig, optional
        Default: `railnav.simulation.trip.navigator_config_for(scenario)`.
    clean : RunOutcome, optional
        The fault-free run of the same seed and config, if already made.
    systems : str
    """
    faults = tuple(faults)
    faulted = run_simulated(track, scenario, config=config, seed=seed, systems=systems,
                            faults=faults)
    if clean is None:
        clean = run_simulated(track, scenario, config=config, seed=seed, systems=systems)
    inn = faulted.result.innovations
    faulty, error = faulty_rows(inn, faults)
    not_used = (inn["status"] != "used").to_numpy()
    detectable = faulty & (np.abs(error) >= DETECTABLE_SIGMA * inn["sigma"].to_numpy())
    start = min(f.start_s for f in faults)
    t = inn["time_s"].to_numpy()
    excluded = (inn["status"] == "excluded").to_numpy()
    pull, worst = _pull(faulted, clean, faults)
    waiting, delay = _readmission(inn, faults)
    fault_free = ~faulty & ~waiting
    return FaultCaseResult(
        name=name, detection_rate=_share(not_used, detectable),
        detectable_rows=int(detectable.sum()), false_alarm_rate=_share(not_used, fault_free),
        fault_free_rows=int(fault_free.sum()),
        time_to_detect_s=_first(t[faulty & not_used]) - start,
        time_to_exclude_s=_first(t[faulty & excluded]) - start,
        readmission_delay_s=delay, pull_sigma=pull, max_error_sigma=worst,
        clock_jumps=faulted.result.statistics().get("clock_jumps", []),
        faulted=faulted, clean=clean)


def _readmission(inn: pd.DataFrame, faults) -> tuple[npt.NDArray[np.bool_], float]:
    """Rows of faulty channels after their fault, before they are used again; and the
    longest such delay (s)."""
    t = inn["time_s"].to_numpy()
    sv, kind = inn["sv"].to_numpy(), inn["kind"].to_numpy()
    used = (inn["status"] == "used").to_numpy()
    waiting = np.zeros(t.size, dtype=bool)
    delays = []
    for f in faults:
        end = f.start_s + f.duration_s
        kinds = ("pseudorange", "range_rate") if f.affects_doppler else ("pseudorange",)
        after = (sv == f.sv) & np.isin(kind, kinds) & (t >= end)
        back = t[after & used]
        if not after.any() or not math.isfinite(end):
            continue
        first = float(back.min()) if back.size else math.inf
        waiting |= after & (t < first)
        delays.append(first - end)
    return waiting, max(delays) if delays else math.nan


def _share(flag: npt.NDArray[np.bool_], among: npt.NDArray[np.bool_]) -> float:
    return float(flag[among].mean()) if among.any() else math.nan


def _first(t: Array) -> float:
    return float(t.min()) if t.size else math.nan


def _pull(faulted: RunOutcome, clean: RunOutcome, faults) -> tuple[float, float]:
    """Largest fault-caused along-track change and error, in σ_s, inside the windows."""
    t = faulted.errors.time_s
    inside = np.zeros(t.size, dtype=bool)
    for f in faults:
        inside |= (t >= f.start_s) & (t < f.start_s + f.duration_s)
    if not inside.any():
        return math.nan, math.nan
    sigma = faulted.result.estimates["sigma_s_m"].to_numpy()[inside]
    e_f = faulted.errors.along_track_m[inside]
    e_c = np.interp(t[inside], clean.errors.time_s, clean.errors.along_track_m)
    return float(np.max(np.abs(e_f - e_c) / sigma)), float(np.max(np.abs(e_f) / sigma))
