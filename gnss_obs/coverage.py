"""Do the navigation data cover the observations? Checked before any epoch is solved.

Each observation needs a broadcast record of its satellite valid at its time
(`gnss_obs.ephemeris.select_ephemeris`: within `gnss_obs.ephemeris.MAX_AGE_S` of the
record's reference time). When whole systems or the whole time span lack one, the
positioning would run on nothing and fail far from the cause (issue 18: a navigation file
a year older than the observations ended in ``array must not contain infs or NaNs``).
`check_nav_coverage` tells it at the start, naming both files:

* no record of any system the observations use (among those asked for), or records
  whose validity windows miss every observation epoch: `GnssInputError`;
* a system used by the observations with no record (e.g. a GPS-only RINEX 2 file with
  ``--systems GE``), or epochs outside the records' span: one warning with the counts;
  the rest is used.

`check_sp3_coverage` does the same for precise orbits (`gnss_obs.dgps.augment`): an SP3
file of another day is an error, epochs beyond its span a warning.

Per-satellite gaps are not this module's business: `gnss_obs.epoch.split_epochs` counts
the measurements without a valid record.
"""
from __future__ import annotations

import logging

import numpy as np

from gnss_obs.constants import SYSTEM_NAMES
from gnss_obs.ephemeris import MAX_AGE_S
from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import gpst_label as _label

__all__ = ["check_nav_coverage", "check_sp3_coverage"]

log = logging.getLogger(__name__)


def _names(systems) -> str:
    return ", ".join(f"{s} ({SYSTEM_NAMES.get(s, s)})" for s in systems)


def _span(t) -> str:
    return f"{_label(float(np.min(t)))} to {_label(float(np.max(t)))} GPST"


def check_nav_coverage(obs, nav, systems: str, *, table=None) -> None:
    """Raise or warn when `nav` does not cover the observations of `systems`.

    Parameters
    ----------
    obs : RinexObs
        Observations (their ``path`` names them in messages).
    nav : RinexNav
        Broadcast navigation data.
    systems : str
        System letters asked for (``"GE"``).
    table : pandas.DataFrame, optional
        The part of ``obs.table`` that will be used (default: all of it).

    Raises
    ------
    GnssInputError
        No record of any observed system asked for, or no observation epoch within the
        validity of the records; the message names both files and both time spans.
    """
    table = obs.table if table is None else table
    obs_name = obs.path or "the observations"
    # (the distinct letters first: iterating every row of a pandas string column is slow)
    used = [s for s in sorted(set(table["system"].unique())) if s in systems] \
        if len(table) else []
    if not used:
        return                      # nothing to cover: the caller says "no measurements"
    have = [s for s in used if s in MAX_AGE_S and len(nav.records.get(s, ())) > 0]
    if not have:
        raise GnssInputError(f"no navigation records of {_names(used)}, the systems of the "
                             f"observations in {obs_name}", path=nav.path)
    if len(have) < len(used):
        log.warning("%s: no navigation records of %s: the observations of %s in %s are not "
                    "used", nav.path, _names(s for s in used if s not in have),
                    "those systems", obs_name)
    t = table["gps_time_s"].to_numpy()
    inside = np.zeros(t.size, dtype=bool)
    system = table["system"].to_numpy()
    spans = []
    for s in have:
        ref = nav.records[s]["toc_gps_s" if s == "R" else "toe_gps_s"].to_numpy(dtype=float)
        lo, hi = np.nanmin(ref) - MAX_AGE_S.get(s, 0.0), np.nanmax(ref) + MAX_AGE_S.get(s, 0.0)
        spans.append((lo, hi))
        inside |= (system == s) & (t >= lo) & (t <= hi)
    considered = np.isin(system, have)
    epochs = np.unique(t[considered])
    covered = np.unique(t[inside])
    nav_span = _span([lo for lo, _ in spans] + [hi for _, hi in spans])
    if covered.size == 0:
        raise GnssInputError(f"the navigation records (valid {nav_span}) do not cover the "
                             f"observations of {obs_name} ({_span(epochs)}): a navigation "
                             "file of another day?", path=nav.path)
    if covered.size < epochs.size:
        log.warning("%s: %d of %d observation epochs of %s (%s) are outside the navigation "
                    "records' validity (%s)", nav.path, epochs.size - covered.size,
                    epochs.size, obs_name, _span(epochs), nav_span)


def check_sp3_coverage(obs, sp3_files) -> None:
    """Raise or warn when the SP3 products do not span the observation epochs.

    Parameters
    ----------
    obs : RinexObs
    sp3_files : sequence of Sp3

    Raises
    ------
    GnssInputError
        No observation epoch within the products' span (orbits of another day).
    """
    if not sp3_files or not len(obs.table):
        return
    t_sp3 = np.concatenate([s.table["gps_time_s"].to_numpy() for s in sp3_files])
    lo, hi = float(np.min(t_sp3)), float(np.max(t_sp3))
    epochs = np.unique(obs.table["gps_time_s"].to_numpy())
    inside = (epochs >= lo) & (epochs <= hi)
    names = ", ".join(s.path or "SP3" for s in sp3_files)
    obs_name = obs.path or "the observations"
    if not inside.any():
        raise GnssInputError(f"the precise orbits ({_span([lo, hi])}) do not cover the "
                             f"observations of {obs_name} ({_span(epochs)})", path=names)
    if not inside.all():
        log.warning("%s: %d of %d observation epochs of %s are outside the precise orbits "
                    "(%s): their satellites have no orbit", names, int((~inside).sum()),
                    epochs.size, obs_name, _span([lo, hi]))
