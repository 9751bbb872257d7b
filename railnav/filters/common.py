"""Pieces shared by the filter objects (most by those whose position is the distance ``s``).

* `EpochRowBuilder`: an epoch's pseudorange/range-rate `ekf.Observation` s at a receiver
  guess, and the per-row record (satellite, kind) for ``innovations.csv``; its subclass
  `GnssRowBuilder` builds them at the prior's point on the track (the unconstrained
  filter's, `railnav.filters.geodetic_rows.GeodeticRowBuilder`, at its geodetic position);
* `states_from_values` (true states for NEES) and `clock_from_fix` (clock states at a
  first GNSS fix), for every filter;
* `start_on_track`: a first GNSS fix projected on the track (``s``, ``v``, clock, their σ).

The columns of ``estimates.csv`` are `railnav.filters.estimate_columns`'s.
"""
from __future__ import annotations

from dataclasses import fields
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.update import Observation
from railnav.filters.gnss_rows import (
    ROW_KINDS,
    GnssRows,
    build_gnss_rows,
    pseudorange_parameters,
    range_rate_parameters,
    track_rows,
)
from railnav.filters.track_frame import antenna_track_part
from trackmodel.earth import C_n_e, ecef_to_geodetic

__all__ = ["EpochRowBuilder", "GnssRowBuilder", "gnss_rows_together", "ROW_KINDS",
           "scalar_point", "REFERENCE_REUSE_M", "states_from_values", "clock_from_fix",
           "start_on_track", "MIN_FIX_SIGMA_S_M", "MIN_FIX_SIGMA_V_MPS", "JACOBIAN_WINDOW_S"]

Array = npt.NDArray[np.float64]

#: Window of the running median of the IMU samples at which the track pseudo-observation's
#: Jacobian is evaluated (`ekf.step.StepOptions.jacobian_window_s`), s. At the raw sample
#: the Jacobian's yaw column on a straight is accelerometer noise, and the filter takes yaw
#: information from it at the sample rate (the 10-h trip's yaw overconfidence,
#: ``docs/consistency-ablations.md``). 0.5 s: 50 samples at 100 Hz (the noise in ``H``
#: down ~6x), over the whole window across the ~1-s chunks (`railnav.navigation.loop`,
#: `railnav.navigation.hypothesis_step`). Not tuned.
JACOBIAN_WINDOW_S = 0.5

#: A reference track point this close to the prior's ``s`` (m) is used as it is: the rows'
#: third-order expansion (`railnav.filters.gnss_rows`) errs by ~δ⁴|d²κ/ds²|/24 (zero on straights,
#: arcs and clothoids; the neglected frame terms are ~1e-10 m⁻²·δ³).
REFERENCE_REUSE_M = 1.0
#: Floors of the initial σ taken from a GNSS fix (a fix's own σ can be optimistic), m, m/s.
MIN_FIX_SIGMA_S_M = 1.0
MIN_FIX_SIGMA_V_MPS = 0.05


@lru_cache(maxsize=64)
def _kind_column(kind: str, n: int) -> np.ndarray:
    """`n` rows of `kind` (an object array, read only: shared by the epochs)."""
    out = np.full(n, kind, dtype=object)
    out.flags.writeable = False
    return out


class EpochRowBuilder:
    """Builds the GNSS rows of an epoch at a receiver guess and remembers what each row was.

    Parameters
    ----------
    rows : railnav.filters.gnss_rows.GnssRows
        The row models (their receiver part comes from the subclass).
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
    config : railnav.NavigatorConfig

    Attributes
    ----------
    rows_sv, rows_kind : list of ndarray
        Per processed epoch, the satellite and kind of each row (in update order).
    latest : (int, ndarray (3,), gnss_obs.PreparedEpoch) or None
        The latest epoch's index, receiver guess (ECEF, m) and satellites prepared there:
        the linearization point a network run's single-point fix of that epoch may start
        from (`railnav.navigation.spp_epochs.EpochSppFixes.solve`).
    """

    def __init__(self, rows: GnssRows, gnss, config) -> None:
        self.rows, self.gnss, self.config = rows, gnss, config
        self.isb_systems = tuple(name.removeprefix("isb_") for name in rows.isb_names)
        self.rows_sv: list[np.ndarray] = []
        self.rows_kind: list[np.ndarray] = []
        self.latest: tuple | None = None

    def rows_at(self, index: int, r_guess_e: Array, part: Array) -> list[Observation]:
        """The rows of GNSS epoch `index`, satellites prepared at `r_guess_e`.

        Parameters
        ----------
        index : int
        r_guess_e : ndarray, shape (3,)
            Receiver position guess, ECEF, m (transmission times, elevations, delays).
        part : ndarray, shape (k,)
            The receiver part of every row (`railnav.filters.gnss_rows.pseudorange_parameters`).
        """
        return self.rows_of(index, r_guess_e, self.gnss.prepare(index, r_guess_e), part)

    def rows_of(self, index: int, r_guess_e: Array, prepared, part: Array
                ) -> list[Observation]:
        """The rows of epoch `index` prepared at `r_guess_e`
        (`railnav.filters.gnss_epochs.GnssEpochs.prepare`) with the receiver part `part`
        (as `rows_at`), recorded in `rows_sv`, `rows_kind` and `latest`."""
        self.latest = (index, r_guess_e, prepared)
        obs, sv, kind = [], [], []
        if len(prepared):
            obs.append(Observation(self.rows.pseudorange, prepared.pseudorange_m[:, None],
                                   prepared.sigma_pr_m ** 2,
                                   pseudorange_parameters(part, prepared, self.isb_systems)))
            sv.append(prepared.sv)
            kind.append(_kind_column(ROW_KINDS[0], len(prepared)))
        if self.config.use_doppler and len(prepared):
            finite = np.isfinite(prepared.range_rate_mps)
            dop = prepared if finite.all() else prepared.subset(finite)
            if len(dop):
                obs.append(Observation(self.rows.range_rate, dop.range_rate_mps[:, None],
                                       dop.sigma_rr_mps ** 2, range_rate_parameters(part, dop)))
                sv.append(dop.sv)
                kind.append(_kind_column(ROW_KINDS[1], len(dop)))
        self.rows_sv.append(np.concatenate(sv) if sv else np.zeros(0, dtype=object))
        self.rows_kind.append(np.concatenate(kind) if kind else np.zeros(0, dtype=object))
        return obs


class GnssRowBuilder(EpochRowBuilder):
    """The GNSS rows of the filters whose position is ``s`` on a track.

    Parameters
    ----------
    track : trackmodel.Track
    layout : ekf.StateLayout
        With states ``s, v, clock_bias, clock_drift`` (+ `isb_names`).
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
    config : railnav.NavigatorConfig
    isb_names : tuple of str
        Inter-system bias states, in the order of ``gnss.config.systems[1:]``.
    """

    def __init__(self, track, layout: StateLayout, gnss, config, isb_names: tuple[str, ...]):
        super().__init__(build_gnss_rows(layout, isb_names), gnss, config)
        self.track, self.layout = track, layout
        self.i_s = layout.index("s")

    def observations(self, index: int, x: Array, reference=None) -> list[Observation]:
        """The rows of GNSS epoch `index` at the prior state ``x``.

        Parameters
        ----------
        index : int
        x : ndarray, shape (n,)
        reference : trackmodel.TrackPoint, optional
            A scalar track point near the prior's ``s`` to linearize at (the rows are exact
            to second order in ``s − s_ref``); queried at ``s`` when absent or farther than
            `REFERENCE_REUSE_M`.
        """
        part = self.receiver_part(x, reference)
        return self.rows_at(index, part[1:4], part)

    def receiver_part(self, x: Array, reference=None) -> Array:
        """The receiver part of the rows at the prior state ``x`` (`observations`'s
        `reference`): `railnav.filters.gnss_rows.track_rows` of the antenna; its
        ``[1:4]`` is the receiver guess (ECEF, m)."""
        s = min(max(float(x[self.i_s]), 0.0), self.track.length_m)
        point = reference
        if point is None or abs(float(point.s) - s) > REFERENCE_REUSE_M:
            point = self.track.at(s)
        part = track_rows(point, earth=self.track.earth)
        antenna = self.config.lever_arms.antenna_m
        if any(antenna):             # the rows of the antenna (railnav.filters.track_frame)
            part = antenna_track_part(self.track, part, antenna)
        return part


def gnss_rows_together(builders, index: int, states, references) -> list[list[Observation]]:
    """`GnssRowBuilder.observations` of several builders (a bank's hypotheses, on one GNSS
    data set) at GNSS epoch `index`: the satellites prepared at all their receiver guesses
    at once (`railnav.filters.gnss_epochs.GnssEpochs.prepare_together`: each builder's rows
    those of its own `observations`, to the bit).

    Parameters
    ----------
    builders : sequence of GnssRowBuilder
    index : int
    states : sequence of ndarray, shape (n,)
        Each builder's prior state.
    references : sequence of trackmodel.TrackPoint or None
        Each builder's reference point (`GnssRowBuilder.observations`).

    Returns
    -------
    list of list of ekf.Observation
        Each builder's rows, in order.
    """
    builders = list(builders)
    parts = [b.receiver_part(x, ref) for b, x, ref in zip(builders, states, references)]
    gnss = builders[0].gnss if builders else None
    if any(b.gnss is not gnss for b in builders):
        return [b.rows_at(index, part[1:4], part) for b, part in zip(builders, parts)]
    guesses = np.array([part[1:4] for part in parts])
    prepared = gnss.prepare_together(index, guesses)
    return [b.rows_of(index, r, one, part)
            for b, r, one, part in zip(builders, guesses, prepared, parts)]


def scalar_point(points, i: int):
    """Element `i` of a `trackmodel.TrackPoint` of arrays, as a scalar point."""
    return type(points)(**{f.name: getattr(points, f.name)[i] for f in fields(points)})


def states_from_values(layout: StateLayout, values: dict, k: int
                       ) -> tuple[Array, npt.NDArray[np.bool_]]:
    """True states from named values (a filter's ``truth_states``).

    Parameters
    ----------
    layout : ekf.StateLayout
    values : dict of str to ndarray (k,) or float
        The known states by name.
    k : int
        Number of samples.

    Returns
    -------
    x_true : ndarray, shape (k, n)
        Unknown components (IMU biases) are 0.
    known : ndarray of bool, shape (n,)
        The named states, and the inter-system biases (the simulator has one receiver
        clock for every system: they are 0).
    """
    x = np.zeros((k, layout.size))
    known = np.zeros(layout.size, dtype=bool)
    for i, name in enumerate(layout.names):
        if name in values:
            x[:, i], known[i] = values[name], True
        elif name.startswith("isb_"):
            known[i] = True
    return x, known


def clock_from_fix(config, fix, isb_names: tuple[str, ...]) -> dict[str, float]:
    """Receiver clock states at a GNSS fix: the clock of the first system, and each
    inter-system bias as the difference to it (0 when the fix has none).

    Parameters
    ----------
    config : railnav.NavigatorConfig
    fix : railnav.navigation.initialization.GnssFix
    isb_names : tuple of str
        Inter-system bias states (``isb_<system>``).

    Returns
    -------
    dict of str to float
        ``clock_bias`` (m), ``clock_drift`` (m/s) and the `isb_names` (m).
    """
    bias = fix.clock_bias_m.get(config.measurement.systems[0], 0.0)
    values = {"clock_bias": bias, "clock_drift": fix.clock_drift_mps}
    for name in isb_names:
        other = fix.clock_bias_m.get(name.removeprefix("isb_"), np.nan)
        values[name] = other - bias if np.isfinite(other) else 0.0
    return values


def start_on_track(track, config, fix, isb_names: tuple[str, ...], *, restart: bool = False
                   ) -> tuple[dict, float, float]:
    """A GNSS fix projected on the track: state values and the σ of ``s`` and ``v``.

    The fix is projected on the track (``s``); the speed is the fix velocity along the
    tangent (signed: negative towards the track start); the clock is the fix's clock of the
    first system and each inter-system bias the difference to it (0 when the fix has none).

    Parameters
    ----------
    track : trackmodel.Track
    config : railnav.NavigatorConfig
        Its ``initial_s_sigma_m`` / ``initial_v_sigma_mps`` override the fix's σ (not for a
        `restart`).
    fix : railnav.navigation.initialization.GnssFix
    isb_names : tuple of str
        Inter-system bias states (``isb_<system>``).
    restart : bool
        A divergence monitor's restart (`railnav.navigation.monitor`): the fix's own σ, as
        the configured ones describe the run's start (a simulated run's truth start: σ_v
        0.1 m/s restarted the ring of `tests/railnav/filters/test_start_attitude.py` from a
        single-point fix whose speed was 0.41 m/s off, 4σ, and it stayed beyond 3σ_s).

    Returns
    -------
    values : dict of str to float
        ``s, v, clock_bias, clock_drift`` and the `isb_names`; plus ``point``, the
        `trackmodel.TrackPoint` at ``s``.
    sigma_s_m, sigma_v_mps : float
        Floored at `MIN_FIX_SIGMA_S_M` / `MIN_FIX_SIGMA_V_MPS`.
    """
    lat, lon, h = ecef_to_geodetic(fix.r_e, earth=track.earth)
    s0 = float(track.project(lat, lon, h).s[0])
    point = track.at(s0)
    t_n = np.asarray(point.u_n, dtype=float)
    t_e = C_n_e(point.lat, point.lon) @ t_n
    sigma_s = (not restart and config.initial_s_sigma_m) or max(
        float(np.sqrt(t_n @ fix.cov_enu_m2 @ t_n)), MIN_FIX_SIGMA_S_M)
    sigma_v = (not restart and config.initial_v_sigma_mps) or max(
        float(np.sqrt(t_n @ fix.cov_v_enu_m2ps2 @ t_n)), MIN_FIX_SIGMA_V_MPS)
    values = {"point": point, "s": s0, "v": float(t_e @ fix.v_e),
              **clock_from_fix(config, fix, isb_names)}
    return values, sigma_s, sigma_v
