"""Fix σ from the fix class where the file gives none: the documented, overridable table.

A fix file may carry its own accuracy (NMEA GST, u-blox hAcc/vAcc/sAcc and NAV-COV, the σ
columns of a CSV): those σ are kept. Where it gives none, the fix class (`FIX_QUALITIES`,
from the receiver's own flag) sets them through `DEFAULT_FIX_SIGMAS`, one `FixSigmas` per
class. The values are 1σ per horizontal axis (east, north), vertical, and of the speed,
rounded up from receiver datasheets for an open-sky antenna (horizontal accuracies quoted
as CEP converted with σ = CEP / 1.1774, the circular-normal median radius):

================  ========  ========  ============  ============================================
class             σ_h (m)   σ_v (m)   σ_speed (m/s) basis
================  ========  ========  ============  ============================================
rtk_fixed         0.03      0.05      0.03          1 cm + 1 ppm (NovAtel OEM7 RTK RMS; u-blox
                                                    ZED-F9P 0.01 m + 1 ppm CEP) at ~20 km
rtk_float         0.5       1.0       0.03          NovAtel OEM7: float solutions 0.2–0.5 m
dgps              0.7       1.5       0.05          NovAtel OEM7 DGPS 0.4 m, SBAS 0.6 m RMS
single            2.5       5.0       0.1           u-blox M8 2.5 m CEP (2.1 m σ), NovAtel L1
                                                    1.5 m RMS; rounded up for rail multipath
dead_reckoning    10.0      10.0      0.5           a receiver's inertial propagation drifts by
                                                    metres within tens of seconds; a guess
================  ========  ========  ============  ============================================

Override any class with `fix_sigma_table` (API) or ``railnav run --fix-sigma
single=4,8`` (`parse_fix_sigma`). The filters still screen every fix against the track
and the prior (`railnav.filters.fault_detection`): a σ that is too small shows as
rejected fixes and a large NIS, not as a silent error.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:                 # pandas is imported where a table is built
    import pandas as pd

from gnss_obs.errors import GnssError
from gnss_obs.fixes.table import FIX_QUALITIES

__all__ = ["FixSigmas", "DEFAULT_FIX_SIGMAS", "fix_sigma_table", "apply_fix_sigmas",
           "parse_fix_sigma"]


@dataclass(frozen=True)
class FixSigmas:
    """1σ of a fix class.

    Parameters
    ----------
    horizontal_m : float
        Per horizontal axis (east, north), m, > 0.
    vertical_m : float
        m, > 0.
    speed_mps : float
        Of the speed over ground, m/s, > 0.
    """

    horizontal_m: float
    vertical_m: float
    speed_mps: float

    def __post_init__(self) -> None:
        for name in ("horizontal_m", "vertical_m", "speed_mps"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise GnssError(f"fix sigma {name} must be a finite number > 0, got {value!r}")


#: The σ of each fix class (module docstring).
DEFAULT_FIX_SIGMAS: dict[str, FixSigmas] = {
    "rtk_fixed": FixSigmas(0.03, 0.05, 0.03),
    "rtk_float": FixSigmas(0.5, 1.0, 0.03),
    "dgps": FixSigmas(0.7, 1.5, 0.05),
    "single": FixSigmas(2.5, 5.0, 0.1),
    "dead_reckoning": FixSigmas(10.0, 10.0, 0.5),
}


def fix_sigma_table(overrides: dict[str, FixSigmas] | None = None) -> dict[str, FixSigmas]:
    """`DEFAULT_FIX_SIGMAS` with the classes in `overrides` replaced.

    Raises
    ------
    GnssError
        For a class not in `FIX_QUALITIES`.
    """
    table = dict(DEFAULT_FIX_SIGMAS)
    for quality, sigmas in (overrides or {}).items():
        if quality not in FIX_QUALITIES:
            raise GnssError(f"unknown fix quality {quality!r} (known: {', '.join(FIX_QUALITIES)})")
        table[quality] = sigmas
    return table


def parse_fix_sigma(text: str, table: dict[str, FixSigmas] | None = None
                    ) -> tuple[str, FixSigmas]:
    """``QUALITY=H[,V[,SPEED]]`` (m, m, m/s) -> the class and its σ (unset values from
    `table`, default `DEFAULT_FIX_SIGMAS`).

    Raises
    ------
    GnssError
        Bad syntax, unknown class or a value that is not a number > 0.
    """
    quality, sep, values = text.partition("=")
    quality = quality.strip()
    if not sep or quality not in FIX_QUALITIES:
        raise GnssError(f"{text!r} is not QUALITY=H[,V[,SPEED]] with QUALITY one of "
                        f"{', '.join(FIX_QUALITIES)}")
    base = (table or DEFAULT_FIX_SIGMAS)[quality]
    try:
        numbers = [float(v) for v in values.split(",")]
    except ValueError:
        raise GnssError(f"{text!r}: the σ must be numbers (m, m, m/s)") from None
    if not 1 <= len(numbers) <= 3:
        raise GnssError(f"{text!r}: give 1 to 3 values H[,V[,SPEED]]")
    names = ("horizontal_m", "vertical_m", "speed_mps")
    return quality, replace(base, **dict(zip(names, numbers)))


def apply_fix_sigmas(table: pd.DataFrame, sigmas: dict[str, FixSigmas] | None = None
                     ) -> pd.DataFrame:
    """The fix table with every missing σ filled from its class.

    The horizontal σ (east, north and their covariance) come from the file for a fix that
    has both, else from its class; the vertical and the speed σ each likewise.
    ``sigma_source`` says where the horizontal σ came from (``file`` or ``table``).

    Parameters
    ----------
    table : pandas.DataFrame
        `gnss_obs.fixes.table.FIX_COLUMNS`.
    sigmas : dict of str to FixSigmas, optional
        Default `DEFAULT_FIX_SIGMAS`.

    Returns
    -------
    pandas.DataFrame
        A copy.
    """

    sigmas = sigmas or DEFAULT_FIX_SIGMAS
    out = table.copy()
    quality = out["quality"].to_numpy()
    lookup = {name: np.array([getattr(sigmas[q], name) for q in quality], dtype=float)
              for name in ("horizontal_m", "vertical_m", "speed_mps")}
    has_file = np.isfinite(out["sigma_east_m"].to_numpy()) & np.isfinite(
        out["sigma_north_m"].to_numpy())
    for column in ("sigma_east_m", "sigma_north_m"):
        out[column] = np.where(has_file, out[column].to_numpy(), lookup["horizontal_m"])
    out["cov_en_m2"] = np.where(has_file, out["cov_en_m2"].to_numpy(), 0.0)
    up = out["sigma_up_m"].to_numpy()
    out["sigma_up_m"] = np.where(np.isfinite(up), up, lookup["vertical_m"])
    speed = out["sigma_speed_mps"].to_numpy()
    out["sigma_speed_mps"] = np.where(np.isfinite(speed), speed, lookup["speed_mps"])
    out["sigma_source"] = np.where(has_file, "file", "table").astype(object)
    return out
