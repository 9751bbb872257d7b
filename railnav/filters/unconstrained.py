"""The unconstrained, tightly coupled INS/GNSS filter: the baseline without a track.

`UnconstrainedFilter` is what `railnav.navigate` drives for ``filter="unconstrained"``:
the full 9-state mechanization with the receiver clock (and IMU biases when the
configuration estimates them, `railnav.filters.unconstrained_model`), updated with pseudoranges
and range rates at the prior's geodetic position (`railnav.filters.geodetic_rows`). It is what a
user would run without a track, on the same engine, measurement models and data as the
constrained filter, and tuned alike: the same IMU and clock densities
(`railnav.filters.ins_clock_model`), GNSS σ, gate and initial attitude, clock and bias σ.

The track is used only

* at the start from a GNSS fix, for the initial attitude (yaw = the track's azimuth,
  pitch = its elevation, roll = 0: the same alignment the constrained filter gets), and
* for the outputs: ``s_m`` is the estimate projected on the track (`Track.project`), and
  ``speed_mps`` the estimated velocity along the track's tangent there (signed, positive
  towards +s, like the constrained filter's ``v``; ``|v_n|`` would hide a reversed
  velocity and is not comparable with the truth's signed speed).

Position σ in metres come from the (lat, lon, h) covariance through
``dE = (R_N + h) cos φ dλ``, ``dN = (R_M + h) dφ``, ``dU = dh``: ``sigma_east_m``,
``sigma_north_m``, ``sigma_up_m``, and ``sigma_s_m`` / ``sigma_cross_track_m`` along and
across the horizontal tangent at the projected point.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ekf.packing import unpack_sym
from ekf.update import Observation
from gnss_obs.oscillator import oscillator_from_name
from railnav.config import NavigatorConfig
from railnav.filters.common import (
    MIN_FIX_SIGMA_S_M,
    MIN_FIX_SIGMA_V_MPS,
    clock_from_fix,
    states_from_values,
)
from railnav.filters.estimate_columns import estimate_columns
from railnav.filters.geodetic_rows import GeodeticRowBuilder
from railnav.filters.ins_clock_model import (
    initial_variances,
    isb_state_name,
)
from railnav.filters.unconstrained_model import (
    POSITION_STATE_NAMES,
    VELOCITY_STATE_NAMES,
    build_unconstrained_model,
)
from trackmodel.earth import C_n_e, ecef_to_geodetic, radii
from trackmodel.track import Track

__all__ = ["UnconstrainedFilter", "enu_position_covariance"]

Array = npt.NDArray[np.float64]


def enu_position_covariance(P_geodetic: Array, lat: Array, h: Array, *, earth) -> Array:
    """Covariance of a geodetic position in local ENU metres.

    Parameters
    ----------
    P_geodetic : ndarray, shape (K, 3, 3)
        Covariance of ``(lat, lon, h)``: rad², rad·m, m².
    lat, h : ndarray, shape (K,)
        Latitude (rad) and height (m) where the errors are mapped.
    earth : Ellipsoid

    Returns
    -------
    ndarray, shape (K, 3, 3)
        Covariance of ``(east, north, up)``, m².
    """
    R_M, R_N = radii(lat, earth=earth)
    T = np.zeros(np.shape(lat) + (3, 3))
    T[..., 0, 1] = (R_N + h) * np.cos(lat)
    T[..., 1, 0] = R_M + h
    T[..., 2, 2] = 1.0
    return T @ P_geodetic @ np.swapaxes(T, -1, -2)


class UnconstrainedFilter:
    """Model, inputs and GNSS rows of the unconstrained filter (module docstring).

    Parameters
    ----------
    track : trackmodel.Track
        For the outputs and the initial alignment only.
    config : NavigatorConfig
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
    """


    def __init__(self, track: Track, config: NavigatorConfig, gnss=None) -> None:
        self.track, self.config = track, config
        self.model = build_unconstrained_model(track.earth, estimate_biases=config.biases_estimated,
                     isb_systems=tuple(config.measurement.systems[1:]))
        # the noise densities of the IMU grade and oscillator the filter assumes
        self.q_c = self.model.process_noise_density(config.imu,
                                                    oscillator_from_name(config.oscillator))
        self.layout, self.process = self.model.layout, self.model.process
        self.isb_names = tuple(isb_state_name(s) for s in self.model.isb_systems)
        self.rows = GeodeticRowBuilder(self.layout, gnss, config, self.isb_names,
                                       earth=track.earth)
        self._i_pos = [self.layout.index(n) for n in POSITION_STATE_NAMES]
        self._i_vel = [self.layout.index(n) for n in VELOCITY_STATE_NAMES]

    # -- engine ----------------------------------------------------------------------------
    def inputs(self, t: Array, u: Array, x_prev: Array, P_prev: Array,
               t_prev: float) -> tuple[Array, Array, None]:
        """The IMU samples ``u`` (M, 6) as they are, and no per-step parameter (M, 0)."""
        return u, np.zeros((np.size(t), 0)), None

    def observations(self, index: int, x: Array, P: Array) -> list[Observation]:
        """GNSS rows of epoch `index` at the prior ``x`` (`GeodeticRowBuilder`)."""
        return self.rows.observations(index, x)

    # -- start -----------------------------------------------------------------------------
    def initial_covariance(self, *, sigma_s_m: float, sigma_v_mps: float) -> Array:
        """Diagonal initial covariance in the layout's order.

        Parameters
        ----------
        sigma_s_m : float
            1σ of the position, m, on EACH axis (east, north and up: the along-track σ of
            the constrained filter becomes a horizontal σ per axis, used for the height
            too), converted to latitude and longitude at the track's start.
        sigma_v_mps : float
            1σ of each ENU velocity component, m/s.
        """
        start = self.track.at(0.0)
        return self._covariance(np.full(3, sigma_s_m), np.full(3, sigma_v_mps),
                                float(start.lat), float(start.h))

    def _covariance(self, sigma_enu_m: Array, sigma_v_enu_mps: Array, lat: float,
                    h: float) -> Array:
        R_M, R_N = radii(lat, earth=self.track.earth)
        var = initial_variances(self.config, self.layout)
        var.update(zip(VELOCITY_STATE_NAMES, np.square(sigma_v_enu_mps)))
        var.update(zip(POSITION_STATE_NAMES, (
            (sigma_enu_m[1] / (R_M + h)) ** 2,
            (sigma_enu_m[0] / ((R_N + h) * np.cos(lat))) ** 2, sigma_enu_m[2] ** 2)))
        return np.diag([var[name] for name in self.layout.names])

    def initial_from_fix(self, fix, *, restart: bool = False) -> tuple[Array, Array]:
        """State and covariance at a GNSS fix (`railnav.navigation.initialization.GnssFix`).

        Position and velocity are the fix's, with the config's σ when given, else the fix's
        own per axis (floored at `railnav.filters.common.MIN_FIX_SIGMA_S_M` /
        `MIN_FIX_SIGMA_V_MPS`); the attitude is the track's where the fix projects (module
        docstring); the clock is the fix's (`railnav.filters.common.clock_from_fix`).
        `restart` (a divergence monitor's): the fix's own σ
        (`railnav.filters.common.start_on_track`).
        """
        lat, lon, h = (float(c) for c in ecef_to_geodetic(fix.r_e, earth=self.track.earth))
        v_n = C_n_e(lat, lon).T @ np.asarray(fix.v_e, dtype=float)
        point = self.track.at(float(self.track.project(lat, lon, h).s[0]))
        values = {"yaw": float(point.azimuth), "pitch": float(point.elevation), "roll": 0.0,
                  "lat": lat, "lon": lon, "h": h, **dict(zip(VELOCITY_STATE_NAMES, v_n)),
                  **clock_from_fix(self.config, fix, self.isb_names)}
        x0 = np.array([values.get(name, 0.0) for name in self.layout.names])
        sigma_pos = np.full(3, self.config.initial_s_sigma_m) \
            if self.config.initial_s_sigma_m and not restart else \
            np.maximum(np.sqrt(np.diag(fix.cov_enu_m2)), MIN_FIX_SIGMA_S_M)
        sigma_vel = np.full(3, self.config.initial_v_sigma_mps) \
            if self.config.initial_v_sigma_mps and not restart else \
            np.maximum(np.sqrt(np.diag(fix.cov_v_enu_m2ps2)), MIN_FIX_SIGMA_V_MPS)
        return x0, self._covariance(sigma_pos, sigma_vel, lat, h)

    def truth_states(self, truth, clock_bias_m: Array, clock_drift_mps: Array
                     ) -> tuple[Array, npt.NDArray[np.bool_]]:
        """True states of the K samples of `truth` (``yaw, pitch, roll, lat, lon, h`` (K,),
        ``v_n`` (K, 3)) with the true clock (m, m/s; (K,) each), and which states are known:
        all but the IMU biases (`railnav.filters.common.states_from_values`)."""
        v_n = np.asarray(truth.v_n, dtype=float)
        values = {"yaw": truth.yaw, "pitch": truth.pitch, "roll": truth.roll,
                  "lat": truth.lat, "lon": truth.lon, "h": truth.h,
                  "clock_bias": clock_bias_m, "clock_drift": clock_drift_mps,
                  **{name: v_n[:, k] for k, name in enumerate(VELOCITY_STATE_NAMES)}}
        return states_from_values(self.layout, values, np.size(truth.lat))

    # -- outputs ---------------------------------------------------------------------------
    def estimates(self, x: Array, P_packed: Array) -> dict[str, Array]:
        """Estimate columns (`railnav.navigation.result`) of stored states (module docstring).

        Parameters
        ----------
        x : ndarray, shape (K, n)
        P_packed : ndarray, shape (K, n(n+1)/2)

        Returns
        -------
        dict of str to ndarray (K,)
        """
        P = unpack_sym(P_packed)
        var = np.diagonal(P, axis1=1, axis2=2)
        lat, lon, h = (x[:, i] for i in self._i_pos)
        v_n = x[:, self._i_vel]
        s = self.track.project(lat, lon, h).s
        u = self.track.at(s).u_n
        t_h = u * np.array([1.0, 1.0, 0.0])
        t_h /= np.linalg.norm(t_h, axis=1)[:, None]
        across = np.column_stack([t_h[:, 1], -t_h[:, 0], np.zeros_like(s)])
        P_enu = enu_position_covariance(P[:, self._i_pos][:, :, self._i_pos], lat, h,
                                        earth=self.track.earth)
        P_vel = P[:, self._i_vel][:, :, self._i_vel]
        cols = {"s_m": s, "lat_deg": np.degrees(lat), "lon_deg": np.degrees(lon), "h_m": h,
                "speed_mps": np.einsum("ki,ki->k", v_n, u), "v_east_mps": v_n[:, 0],
                "v_north_mps": v_n[:, 1], "v_up_mps": v_n[:, 2]}
        return estimate_columns(self.layout, x, var, position=cols, position_sigma={
            "sigma_s_m": _sigma_along(P_enu, u),
            "sigma_cross_track_m": _sigma_along(P_enu, across),
            "sigma_east_m": np.sqrt(P_enu[:, 0, 0]), "sigma_north_m": np.sqrt(P_enu[:, 1, 1]),
            "sigma_up_m": np.sqrt(P_enu[:, 2, 2]), "sigma_speed_mps": _sigma_along(P_vel, u)})


def _sigma_along(P: Array, d: Array) -> Array:
    """σ of ``d · e`` for errors ``e`` of covariance ``P`` (K, 3, 3), ``d`` (K, 3)."""
    return np.sqrt(np.einsum("ki,kij,kj->k", d, P, d))
