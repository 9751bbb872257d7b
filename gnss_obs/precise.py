"""Precise satellite orbits and clocks (SP3) in place of the broadcast ephemeris.

`PreciseOrbits.from_sp3` keeps, per satellite, the SP3 nodes (`gnss_obs.sp3`); `states`
evaluates many satellites at many times in one call and returns the broadcast module's
`SatelliteStates`, so `gnss_obs.transmission.transmit_states(..., precise=...)` swaps
orbits and clocks without changing anything downstream:

* position: Lagrange interpolation of degree `order` on the nearest nodes (as
  `Sp3.interpolate`); velocity: central difference of the interpolant over ±`_DT_S`;
* clock: linear between the two bracketing nodes; drift: their slope;
* relativity: SP3 clocks leave out the periodic relativistic term (IGS convention), so
  ``-2 r·v / c²`` is added to `clock_s` (and reported in `relativity_s`), which makes
  them comparable with the broadcast clocks that include it.

What is not modelled: SP3 positions are centres of mass, the broadcast ones antenna phase
centres (GPS up to ~1-2 m, mostly radial, largely absorbed by the receiver clock; it
cancels in DGNSS); clock datums differ from the broadcast ones by a per-system constant
(absorbed by the per-system receiver clocks); satellites or times outside the file give
NaN states, which `prepare_epoch` drops (e.g. BeiDou in a GPS/GLONASS/Galileo product).
The broadcast group delays (TGD/BGD) still apply to the code used.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import SPEED_OF_LIGHT_MPS
from gnss_obs.errors import GnssInputError
from gnss_obs.kepler import SatelliteStates

__all__ = ["PreciseOrbits"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
#: Half step of the velocity difference, s.
_DT_S = 0.5
#: Largest gap between bracketing nodes, in nominal intervals (as `gnss_obs.sp3`).
_MAX_GAP_INTERVALS = 2.0


def _lagrange_weights(dt: Array) -> Array:
    """Weights of Lagrange interpolation at 0 for nodes at offsets ``dt`` (N, n)."""
    n = dt.shape[1]
    w = np.ones(dt.shape)
    for j in range(n):
        for m in range(n):
            if m != j:
                w[:, j] *= dt[:, m] / (dt[:, m] - dt[:, j])
    return w


@dataclass(frozen=True, eq=False)
class PreciseOrbits:
    """SP3 nodes per satellite: ``nodes[sv] = (t_s (K,), r_e (K, 3), clock_s (K,))``."""

    nodes: dict[str, tuple[Array, Array, Array]]
    interval_s: float
    order: int = 10

    @classmethod
    def from_sp3(cls, *sp3_files, order: int = 10) -> "PreciseOrbits":
        """Merge one or more `Sp3` products (later files win at equal epochs).

        Satellites with fewer than ``order + 1`` valid epochs are left out with a warning
        (a lower-degree interpolation would be kilometres off).

        Raises
        ------
        GnssInputError
            No satellite has enough epochs (e.g. a truncated file).
        """
        import pandas as pd

        table = pd.concat([s.table for s in sp3_files], ignore_index=True)
        table = table.drop_duplicates(["sv", "gps_time_s"], keep="last")
        table = table[table["x_m"].notna()].sort_values(["sv", "gps_time_s"])
        groups = dict(list(table.groupby("sv")))
        nodes = {str(sv): (g["gps_time_s"].to_numpy(), g[["x_m", "y_m", "z_m"]].to_numpy(),
                           g["clock_s"].to_numpy())
                 for sv, g in groups.items() if len(g) > order}
        names = ", ".join(s.path or "SP3" for s in sp3_files)
        if not nodes:
            raise GnssInputError(f"no satellite has the {order + 1} valid epochs a degree-"
                                 f"{order} interpolation needs (truncated file?)", path=names)
        if len(nodes) < len(groups):
            few = sorted(str(sv) for sv in groups if str(sv) not in nodes)
            log.warning("%s: %d satellites with fewer than %d valid epochs are not used (%s)",
                        names, len(few), order + 1, " ".join(few))
        return cls(nodes, float(min(s.interval_s for s in sp3_files)), order)

    def _position(self, t_nodes: Array, r_nodes: Array, t: Array) -> Array:
        n = min(self.order + 1, len(t_nodes))
        first = np.clip(np.searchsorted(t_nodes, t) - n // 2, 0, len(t_nodes) - n)
        window = first[:, None] + np.arange(n)
        w = _lagrange_weights(t_nodes[window] - t[:, None])
        return np.einsum("in,ink->ik", w, r_nodes[window])

    def _one(self, sv: str, t: Array):
        t_nodes, r_nodes, clk = self.nodes[sv]
        right = np.clip(np.searchsorted(t_nodes, t, side="right"), 1, len(t_nodes) - 1)
        t0, t1 = t_nodes[right - 1], t_nodes[right]
        bad = (t < t_nodes[0]) | (t > t_nodes[-1]) | (t1 - t0 > _MAX_GAP_INTERVALS
                                                      * self.interval_s)
        r = self._position(t_nodes, r_nodes, t)
        v = (self._position(t_nodes, r_nodes, t + _DT_S)
             - self._position(t_nodes, r_nodes, t - _DT_S)) / (2 * _DT_S)
        drift = (clk[right] - clk[right - 1]) / (t1 - t0)
        clock = clk[right - 1] + drift * (t - t0)
        r[bad], v[bad], clock[bad], drift[bad] = np.nan, np.nan, np.nan, np.nan
        return r, v, clock, drift

    def states(self, sv: npt.ArrayLike, t_gps_s: npt.ArrayLike) -> SatelliteStates:
        """Satellite states at the given times (NaN for satellites/times not covered).

        Parameters
        ----------
        sv : array_like of str, shape (N,)
        t_gps_s : array_like, shape (N,)
            Evaluation (transmission) times, s since the GPS epoch.

        Returns
        -------
        SatelliteStates
            ECEF of the evaluation instant (the SP3 frame); clock with the relativistic
            term added.
        """
        sv = np.asarray(sv).astype(str)
        t = np.broadcast_to(np.asarray(t_gps_s, dtype=float), sv.shape).copy()
        n = sv.size
        r, v = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
        clock, drift = np.full(n, np.nan), np.full(n, np.nan)
        for name in np.unique(sv):
            if name not in self.nodes:
                continue
            m = (sv == name) & np.isfinite(t)
            if m.any():
                r[m], v[m], clock[m], drift[m] = self._one(name, t[m])
        rel = -2.0 * np.einsum("ij,ij->i", r, v) / SPEED_OF_LIGHT_MPS ** 2
        return SatelliteStates(r, v, clock + rel, drift, rel)
