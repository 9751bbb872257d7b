r"""GNSS pseudorange and range-rate rows for a state with geodetic position and ENU velocity.

The unconstrained filter's receiver is wherever its state says (ARCHITECTURE.md, "GNSS")::

    r_e = [(R_N + h) cos φ cos λ,  (R_N + h) cos φ sin λ,  (R_N (1 − e²) + h) sin φ]
    v_e = C_n_e(φ, λ) v_n

with ``R_N`` the prime-vertical radius of the filter's `trackmodel.earth.Ellipsoid`. The
observation equations are `gnss_obs.observables` (the one implementation, shared with the
SPP and the track-based rows), composed with this receiver by
`railnav.filters.gnss_rows.compose_gnss_rows` so that CasADi differentiates through the geodetic
position exactly (no linearization point: the rows have no receiver parameters).

`geodetic_to_ecef_sx` and `C_n_e_sx` are the symbolic forms of
`trackmodel.earth.geodetic_to_ecef` and `trackmodel.earth.C_n_e` (the owners), tested
against them.

Row parameters (the satellite's only, as in `railnav.filters.gnss_rows`)::

    pseudorange: [sat_pos_e (3), sat_clock_m, delays_m, system selector (one per ISB state)]
    range rate:  [sat_pos_e (3), sat_vel_e (3), sat_clock_drift_mps]
"""
from __future__ import annotations

import functools
from typing import Any

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.update import Observation
from railnav.filters.common import EpochRowBuilder
from railnav.filters.gnss_rows import GnssRows, compose_gnss_rows
from railnav.filters.unconstrained_model import (
    POSITION_STATE_NAMES,
    VELOCITY_STATE_NAMES,
)
from strapdown.frames import radii_of_curvature
from trackmodel.earth import Ellipsoid, geodetic_to_ecef

__all__ = ["geodetic_to_ecef_sx", "C_n_e_sx", "build_geodetic_rows", "GeodeticRowBuilder"]

Array = npt.NDArray[np.float64]

#: No receiver parameters precede the satellite's in a row.
_NO_PART = np.zeros(0)


def geodetic_to_ecef_sx(lat: Any, lon: Any, h: Any, *, earth: Ellipsoid) -> ca.SX:
    """ECEF position of geodetic coordinates, symbolic (casadi 3x1, m).

    Parameters
    ----------
    lat, lon : casadi scalar
        Geodetic latitude and longitude, rad.
    h : casadi scalar
        Ellipsoidal height, m.
    earth : Ellipsoid
    """
    _, R_N = radii_of_curvature(lat, earth=earth)
    cos_lat = ca.cos(lat)
    return ca.vertcat((R_N + h) * cos_lat * ca.cos(lon), (R_N + h) * cos_lat * ca.sin(lon),
                      (R_N * (1.0 - earth.e2) + h) * ca.sin(lat))


def C_n_e_sx(lat: Any, lon: Any) -> ca.SX:
    """Rotation ENU -> ECEF at a geodetic position, symbolic (casadi 3x3).

    Columns are east, north and up in ECEF (``v_e = C_n_e v_n``).
    """
    sl, cl, so, co = ca.sin(lat), ca.cos(lat), ca.sin(lon), ca.cos(lon)
    east = ca.vertcat(-so, co, 0.0)
    north = ca.vertcat(-sl * co, -sl * so, cl)
    up = ca.vertcat(cl * co, cl * so, sl)
    return ca.horzcat(east, north, up)


@functools.lru_cache(maxsize=None)
def build_geodetic_rows(layout: StateLayout, isb_names: tuple[str, ...] = (), *,
                        earth: Ellipsoid) -> GnssRows:
    """Row models for a layout with ``lat, lon, h, v_E, v_N, v_U`` and the clock states.

    Parameters
    ----------
    layout : ekf.StateLayout
        Must name `POSITION_STATE_NAMES`, `VELOCITY_STATE_NAMES`, ``clock_bias``,
        ``clock_drift`` and each of `isb_names`.
    isb_names : tuple of str
        Inter-system bias states (m).
    earth : Ellipsoid
        The ellipsoid of the geodetic coordinates.

    Returns
    -------
    GnssRows
    """
    i_pos = [layout.index(n) for n in POSITION_STATE_NAMES]
    i_vel = [layout.index(n) for n in VELOCITY_STATE_NAMES]

    def receiver(x: ca.SX, part: ca.SX) -> tuple[ca.SX, ca.SX]:
        lat, lon, h = (x[i] for i in i_pos)
        v_n = ca.vertcat(*(x[i] for i in i_vel))
        return geodetic_to_ecef_sx(lat, lon, h, earth=earth), ca.mtimes(C_n_e_sx(lat, lon), v_n)

    return compose_gnss_rows(layout, tuple(isb_names), receiver, n_part=0, name="geodetic")


class GeodeticRowBuilder(EpochRowBuilder):
    """The GNSS rows of a filter whose position is geodetic, at the prior's position.

    Parameters
    ----------
    layout : ekf.StateLayout
        As for `build_geodetic_rows`.
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
    config : railnav.NavigatorConfig
    isb_names : tuple of str
        Inter-system bias states, in the order of ``gnss.config.systems[1:]``.
    earth : Ellipsoid
    """

    def __init__(self, layout: StateLayout, gnss, config, isb_names: tuple[str, ...], *,
                 earth: Ellipsoid) -> None:
        super().__init__(build_geodetic_rows(layout, tuple(isb_names), earth=earth), gnss,
                         config)
        self.earth = earth
        self._i_pos = [layout.index(n) for n in POSITION_STATE_NAMES]

    def observations(self, index: int, x: Array) -> list[Observation]:
        """The rows of GNSS epoch `index`, satellites prepared at the prior ``x`` (n,)."""
        lat, lon, h = (float(x[i]) for i in self._i_pos)
        return self.rows_at(index, geodetic_to_ecef(lat, lon, h, earth=self.earth), _NO_PART)
