"""The track-constrained, tightly coupled INS/GNSS filter (the 2017 paper's, corrected).

`ConstrainedFilter` is what `railnav.navigate` drives for ``filter="constrained"``: it
holds the process model (`railnav.filters.constrained_model`), turns IMU samples into filter
inputs with the track linearized along the predicted path (the per-step parameters of
`strapdown.reduced`), and turns a GNSS epoch into pseudorange and range-rate rows
(`railnav.filters.gnss_rows`), and a GNSS position fix into fix rows
(`railnav.filters.fix_rows`), at the prior's position on the track, screened at the prior for
faulty satellites and receiver clock jumps (`railnav.filters.fault_detection`,
``config.fault_detection``); pseudoranges correlated from epoch to epoch
(``config.pseudorange_correlation_s`` > 0) with their variances inflated as the gnss-only
filter's (`railnav.filters.gnss_only_noise.pseudorange_inflation`) for the update, and
screened at their own (`railnav.filters.fault_detection`, "Inflated rows").

Reference path of a chunk: from the filter's state at the chunk start, the along-track
distance is predicted with the along-track specific force (`railnav.filters.reference_path`,
its `ReferencePath` part of `ConstrainedFilter`); the track quantities are taken at the
nearest node of a 0.5-m grid (`railnav.filters.track_grid`) and the model corrects them to
first/second order in ``s − s_ref`` (`strapdown.reduced`), so the Jacobians with respect to
``s`` are the track's.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ekf.packing import unpack_sym
from ekf.series import EpochRows
from ekf.update import Observation
from gnss_obs.oscillator import oscillator_from_name
from railnav.config import NavigatorConfig
from railnav.filters.along_force_noise import AlongForceNoise
from railnav.filters.body_rows import BodyRows, body_densities, body_states, mount_truth
from railnav.filters.common import (ROW_KINDS, GnssRowBuilder, start_on_track,
                                    states_from_values)
from railnav.filters.constrained_model import (build_constrained_model, isb_state_name,
                                               scale_elements_for)
from railnav.filters.estimate_columns import track_estimates
from railnav.filters.fault_detection import RowScreen
from railnav.filters.fix_rows import FixRowBuilder, stack_epoch_rows
from railnav.filters.geometry_noise import remainder_correlation_s, statistical_parameters
from railnav.filters.gnss_only_noise import (correlation_inflation, epoch_interval_s,
                                             pseudorange_inflation)
from railnav.filters.grade_noise import unknown_grade_density
from railnav.filters.held_remainder import held_density
from railnav.filters.inputs_together import chunk_median_step, inputs_together, sample_steps
from railnav.filters.ins_clock_model import initial_variances
from railnav.filters.noise_scale import NoiseScale, scaled_gnss_rows
from railnav.filters.one_sided import OneSidedLimit
from railnav.filters.path_noise import PathNoise
from railnav.filters.reference_path import ReferencePath
from railnav.filters.scale_noise import step_nodes
from railnav.filters.sensor_rows import SensorRows, sensor_densities, sensor_states
from railnav.filters.start_attitude import track_attitude, with_track_attitude_covariance
from railnav.filters.track_grid import TrackParameterGrid
from trackmodel.track import Track

__all__ = ["ConstrainedFilter"]

Array = npt.NDArray[np.float64]


class ConstrainedFilter(ReferencePath):
    """Model, inputs and GNSS rows of the constrained filter for one track.

    Parameters
    ----------
    track : trackmodel.Track
    config : NavigatorConfig
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
    fixes : railnav.filters.fix_epochs.FixEpochs, optional
        GNSS position fixes (`railnav.filters.fix_rows`, ``config.fix_model``).
    schedule : railnav.filters.fix_epochs.EpochSchedule, optional
        The epochs of `observations` (default: the GNSS epochs).
    odometer : railnav.filters.odometer_epochs.OdometerEpochs, optional
        Odometer readings (`railnav.filters.odometer_rows`; with them the state may carry
        the scale factor, `railnav.filters.sensor_rows.sensor_states`).
    balises : railnav.filters.balise_rows.BaliseEpochs, optional
        Balise passages (`railnav.filters.balise_rows`).
    body : dict, optional
        The attitude and standstill streams (`railnav.filters.body_rows.body_stream_epochs`;
        with ``config.track_attitude`` the state carries the IMU's mounting).

    Attributes
    ----------
    gnss_interval_s : float
        The GNSS epochs' median interval, s (`railnav.filters.gnss_only_noise.epoch_interval_s`).
    pseudorange_inflation : float
        Factor on the pseudorange variances standing (1: white errors, or no GNSS), for the
        monitor; each epoch's is `railnav.filters.gnss_only_noise.pseudorange_inflation` at
        its prior's speed.
    """


    def __init__(self, track: Track, config: NavigatorConfig, gnss=None, *, fixes=None,
                 schedule=None, odometer=None, balises=None, body=None) -> None:
        self.track, self.config = track, config
        sensor_blocks = sensor_states(config, odometer)
        extra = sensor_blocks + body_states(config)
        #: The IMU's ``S + M`` elements the state carries (`constrained_model.SCALE_ELEMENTS`).
        self.scale_elements = scale_elements_for(biases_estimated=config.biases_estimated,
                                                 imu=config.imu)
        self.model = build_constrained_model(track.earth, estimate_biases=config.biases_estimated,
                     isb_systems=tuple(config.measurement.systems[1:]), extra_blocks=extra,
                     scale_elements=self.scale_elements)
        # the noise densities of the IMU grade and oscillator the filter assumes
        self.q_c = self.model.process_noise_density(config.imu,
                                                    oscillator_from_name(config.oscillator),
                                                    sensor_densities(config, sensor_blocks)
                                                    + body_densities(config))
        self.layout, self.process = self.model.layout, self.model.process
        self.isb_systems = self.model.isb_systems
        self.rows = GnssRowBuilder(track, self.layout, gnss, config,
                                   tuple(isb_state_name(s) for s in self.isb_systems))
        #: The GNSS rows' adaptive noise scale (`railnav.filters.noise_scale`), fed by the
        #: screen's record of each epoch.
        self.noise_scale = NoiseScale(config.noise_scale)
        self.screen = RowScreen(config.fault_detection, self.layout.index("clock_bias"),
                                observer=self.noise_scale.seen)
        self.gnss_interval_s = epoch_interval_s(gnss)
        self.pseudorange_inflation = 1.0 if gnss is None else correlation_inflation(
            config.pseudorange_correlation_s, self.gnss_interval_s)
        self.fix_rows = None if fixes is None else FixRowBuilder(
            track, self.layout, fixes, config.fix_model, antenna_m=config.lever_arms.antenna_m)
        self.sensors = SensorRows(self.layout, config, odometer=odometer, balises=balises)
        self.body = BodyRows(self.layout, track, config, body or {})
        self.schedule = schedule
        self._i = {name: self.layout.index(name) for name in ("pitch", "s", "v")}
        self._b_ax = self.layout.index("b_ax") if self.model.estimate_biases else None
        self._gravity: dict[int, float] = {}
        self._chunk_end = None   # the track at the last sample of the latest chunk
        self._grid = TrackParameterGrid(track)
        #: What the chunk's predicted path adds to `q_c` (`railnav.filters.path_noise`).
        self.path_noise = PathNoise(track, self._grid, self.q_c, self.model.noise_names,
                                    config=config, scale_elements=self.scale_elements,
                                    estimate_biases=self.model.estimate_biases)
        #: The bound on the rows' information near an onset (`railnav.filters.one_sided`;
        #: None with ``config.one_sided`` off).
        self.one_sided = OneSidedLimit(track, self.layout, self.model.noise_names) \
            if config.one_sided else None
        #: The accelerometer biases' step from the along-track specific force
        #: (`railnav.filters.along_force_noise`; None without bias states or without
        #: accelerometer scale factors and misalignments).
        bias_noise = self.path_noise.bias_noise
        self._along = AlongForceNoise.for_grade(config.imu, self._b_ax, bias_noise) \
            if bias_noise is not None else None
        #: ``q_c`` of the latest `inputs` call's samples: `q_c`, or (M, n_w) rows with what
        #: the predicted path adds (`railnav.filters.path_noise`).
        self.step_q_c = self.q_c
        #: The run's nominal sample interval, s (`inputs`; set by the chunk loop).
        self.sample_interval_s: float | None = None

    def use_noise_scale(self, scale) -> None:
        """Scale the GNSS rows by `scale` from now on, and feed it from the fault screen
        (a bank's hypothesis: `railnav.filters.bank_noise_scale.BankNoiseScale.member`)."""
        self.noise_scale = scale
        self.screen.observer = scale.seen

    # -- inputs ----------------------------------------------------------------------------
    def inputs(self, t: Array, u: Array, x_prev: Array, P_prev: Array,
               t_prev: float) -> tuple[Array, Array, Array]:
        """Filter inputs, track parameters and geometry noise of samples ``t``.

        Parameters
        ----------
        t : ndarray, shape (M,)
            Sample times, s (after `t_prev`).
        u : ndarray, shape (M, 6)
            IMU samples ``[f_b, ω_ib_b]`` (m/s², rad/s).
        x_prev : ndarray, shape (n,)
            Filter state at `t_prev`.
        P_prev : ndarray, shape (n, n)
            Its covariance.
        t_prev : float
            Time of `x_prev`, s.

        Returns
        -------
        u : ndarray, shape (M, 6)
        p : ndarray, shape (M, 16)
            `strapdown.reduced.TRACK_PARAMETER_NAMES` at the predicted ``s``.
        r_c : ndarray, shape (M, 2)
            Density of the pseudo-observation noise that the uncertainty of ``s`` puts on
            the track geometry (`railnav.filters.geometry_noise`), (m/s²)²·s: its variance
            times its correlation time (`geometry_noise.remainder_correlation_s`: the time
            to run across ±σ_s, at least the run's nominal sample interval
            `sample_interval_s`, set by the chunk loop; else the chunk's median step). A
            density, not a per-step
            variance, so that jitter, dropped samples and the samples inserted at epochs
            change the information per second of the pseudo-observation by nothing (a
            chunk of one short inserted step would otherwise weigh as a full sample).
        """
        pending = self._start_inputs(t, u, x_prev, P_prev, t_prev)
        return self._finish_inputs(pending, None if pending["paths"] is None else
                                   self.path_noise.densities(pending["paths"],
                                                             pending["speed"],
                                                             pending["steps"]))

    @staticmethod
    def inputs_together(filters, t: Array, u: Array, priors, t_prev: float) -> list:
        """`inputs` of several filters (a bank's hypotheses) over the same samples, each
        from its own prior ``priors[k] = (x_prev, P_prev)``: the same numbers, the work
        that is alike stacked (`railnav.filters.inputs_together`). Returns `inputs`'s
        tuple for each filter, in order."""
        return inputs_together(filters, t, u, priors, t_prev)

    def _start_inputs(self, t: Array, u: Array, x_prev: Array, P_prev: Array,
                      t_prev: float, *, chunk_step: float | None = None,
                      along: Array | None = None) -> dict:
        """`inputs` up to the bias steps' densities: the rest of its results, and the
        grid rows of the spread's paths (``paths``, None without bias noise);
        `chunk_step`: `chunk_step` of these samples, when known; `along`: the
        along-force noise's `force` of them, when computed (`forces_together`)."""
        accel = self._along_accel(u, x_prev)
        s_pred = self.predict_s(t, accel, x_prev, t_prev)
        params = self._path_parameters(s_pred)
        sigma_s, speed = self.prior_spread(x_prev, P_prev)
        step = self.chunk_step(t, t_prev, chunk_step)
        params, variance = statistical_parameters(self._grid, params, sigma_s_m=sigma_s,
                                                  speed_mps=speed, interval_m=speed * step,
                                                  s_m=s_pred)
        r_c = held_density(variance, params, sigma_s_m=sigma_s, speed_mps=speed,
                           correlation_s=remainder_correlation_s(
                               sigma_s_m=sigma_s, speed_mps=speed, step_s=step),
                           held_s=float(t[-1]) - t_prev)
        return self._pending(t, u, x_prev, P_prev, t_prev, accel=accel, s_pred=s_pred,
                             params=params, r_c=r_c, step=step, along=along,
                             speed=speed, sigma_s=sigma_s)

    def _path_parameters(self, s_pred: Array, found=None) -> Array:
        """The grid rows at the predicted path `s_pred` (`TrackParameterGrid.parameters`;
        `found`: its result, when known), the track at its last sample kept for the
        epoch's rows (``_chunk_end``)."""
        params, grid_nodes = self._grid.parameters(s_pred) if found is None else found
        self._chunk_end = self._grid.point(int(grid_nodes[-1]))
        return params

    def prior_spread(self, x_prev: Array, P_prev: Array) -> tuple[float, float]:
        """σ_s (m) and |v| (m/s) of a chunk's prior."""
        i_s = self._i["s"]
        return float(np.sqrt(max(P_prev[i_s, i_s], 0.0))), abs(float(x_prev[self._i["v"]]))

    def chunk_step(self, t: Array, t_prev: float, chunk_step: float | None = None) -> float:
        """The step the chunk's noise assumes: `sample_interval_s`, else the chunk's
        median step (`chunk_step` when already computed)."""
        if self.sample_interval_s is not None:
            return self.sample_interval_s
        return chunk_median_step(t, t_prev) if chunk_step is None else chunk_step

    def _pending(self, t: Array, u: Array, x_prev: Array, P_prev: Array, t_prev: float, *,
                 accel: Array, s_pred: Array, params: Array, r_c: Array, step: float,
                 along: Array | None, speed: float, sigma_s: float,
                 steps: Array | None = None) -> dict:
        """`_start_inputs`'s result from the path, the track parameters and the geometry
        noise `r_c` (`inputs_together` gives them stacked), `speed` and `sigma_s`
        (`prior_spread`): the along-track force, the steps (`steps`: `sample_steps`'s,
        when known), an unknown grade's noise on `r_c` (in place) and the spread's
        paths."""
        if along is None and self._along is not None:
            along = self._along.force(t, u)
        steps = sample_steps(t, step) if steps is None else steps
        nodes = step_nodes(sigma_s)
        if self.config.grade_sigma_rad > 0.0:           # a grade the track does not know
            r_c[:, 1] += unknown_grade_density(accel, speed, self.config.grade_sigma_rad)
        return {"u": u, "params": params, "r_c": r_c,
                "t": t, "t_prev": t_prev, "s_pred": s_pred, "x_prev": x_prev,
                "P_prev": P_prev, "steps": steps, "nodes": nodes,
                "along": along, "speed": speed,
                "paths": None if self.path_noise.bias_noise is None else
                self.path_noise.path_rows(s_pred, float(x_prev[self._i["s"]]), nodes)}

    def _finish_inputs(self, pending: dict, found) -> tuple[Array, Array, Array]:
        """`inputs`'s results from `_start_inputs` and the densities of its paths
        (`path_bias_step_densities`'s, None without); with ``config.one_sided``, ``r_c``
        bounded near an onset (`railnav.filters.one_sided`)."""
        along = None if pending["along"] is None else self._along.densities(
            pending["along"], pending["P_prev"], pending["t"], pending["steps"])
        self.step_q_c = self.path_noise.step_q_c(pending, found, along)
        if along is not None:
            self._along.given(self.step_q_c, pending["t"], float(pending["t_prev"]))
        r_c = pending["r_c"]
        if self.one_sided is not None:
            r_c = self.one_sided(pending["t"], pending["s_pred"], pending["params"], r_c,
                                 pending["x_prev"], pending["P_prev"], self.step_q_c,
                                 float(pending["t_prev"]))
        return pending["u"], pending["params"], r_c

    def inherit_memory(self, parent: "ConstrainedFilter") -> None:
        """Take over `parent`'s memory of the along-track force (where its accelerometer
        biases were last tied, the step variance held; the last sample of its latest
        chunk: `railnav.filters.along_force_noise`): a hypothesis's child
        (`railnav.navigation.network_navigator`) goes on from its parent's state,
        covariance and these."""
        if self._along is not None and parent._along is not None:
            self._along = parent._along.copy()

    # -- discrete updates ------------------------------------------------------------------
    def observations(self, index: int, x: Array, P: Array) -> list[Observation] | EpochRows:
        """GNSS, fix, odometer and balise rows of epoch `index` at the prior ``(x, P)``
        (`GnssRowBuilder`, `railnav.filters.fix_rows.FixRowBuilder`,
        `railnav.filters.sensor_rows.SensorRows`), those the fault screen lets through
        (with a clock jump's covariance when it sees one)."""
        g, f = self.epoch_split(index)
        gnss = None if g < 0 else (self.rows.observations(g, x, self._chunk_end),
                                   self.rows.rows_sv[-1], self.rows.rows_kind[-1])
        rows, sv, kind, modes, groups, inflation = self.epoch_rows(index, f, gnss, x, P)
        return self.screen.screen(rows, sv, kind, x, P, modes=modes, groups=groups,
                                  inflation=inflation)

    def epoch_split(self, index: int) -> tuple[int, int]:
        """The GNSS and fix epochs of schedule epoch `index` (−1: none)."""
        return (index, -1) if self.schedule is None else self.schedule.split(index)

    def epoch_rows(self, index: int, f: int, gnss, x: Array, P: Array) -> tuple:
        """Epoch `index`'s rows before the screen: the GNSS rows `gnss` (``(rows, sv,
        kind)``, None without), fix epoch `f`'s rows, the sensor and body rows, stacked
        (`railnav.filters.fix_rows.stack_epoch_rows`'s tuple), and each row's variance
        inflation (`RowScreen.screen`'s ``inflation``: None when no row is inflated);
        `observations`, and `railnav.filters.epochs_together` for a bank."""
        if self._along is not None:
            self._along.epoch = True
        self.noise_scale.begin_epoch()
        factor = 1.0
        if gnss is not None:
            if self.pseudorange_inflation != 1.0:
                factor = pseudorange_inflation(self.config, float(x[self._i["v"]]),
                                               self.gnss_interval_s)
            gnss = (scaled_gnss_rows(gnss[0], self.rows.rows, pseudorange_factor=factor,
                                     scale=self.noise_scale), *gnss[1:])
        fix = None if f < 0 else self.fix_rows.observations(f, x)
        extra = self.sensors.parts(self.schedule, index, x, P) if self.sensors else []
        if self.body:
            extra = [*extra, *self.body.parts(self.schedule, index, x, P)]
        stacked = stack_epoch_rows(gnss, fix, gnss_mode="channel", fix_group=f, extra=extra)
        inflation = None if factor == 1.0 else \
            np.where(stacked[2] == ROW_KINDS[0], factor, 1.0).astype(float)
        return (*stacked, inflation)

    # -- start -----------------------------------------------------------------------------
    def initial_covariance(self, *, sigma_s_m: float, sigma_v_mps: float) -> Array:
        """Diagonal initial covariance in the layout's order (config's attitude and clock σ)."""
        var = initial_variances(self.config, self.layout)
        var.update({"s": sigma_s_m ** 2, "v": sigma_v_mps ** 2})
        return np.diag([var[name] for name in self.layout.names])

    def initial_from_fix(self, fix, *, restart: bool = False) -> tuple[Array, Array]:
        """State and covariance at a GNSS fix (`railnav.navigation.initialization.GnssFix`).

        The fix is projected on the track (`railnav.filters.common.start_on_track`); the
        attitude is the track's (yaw = azimuth, pitch = elevation, roll = 0), with its error
        from the projection's along-track error in the covariance
        (`railnav.filters.start_attitude`). `restart`: the fix's own σ (`start_on_track`).
        """
        values, sigma_s, sigma_v = start_on_track(
            self.track, self.config, fix, tuple(isb_state_name(s) for s in self.isb_systems),
            restart=restart)
        point = values.pop("point")
        values.update(track_attitude(point))
        x0 = np.array([values.get(name, 0.0) for name in self.layout.names])
        return x0, with_track_attitude_covariance(
            self.initial_covariance(sigma_s_m=sigma_s, sigma_v_mps=sigma_v),
            tuple(self.layout.names), point, sigma_s)

    def truth_states(self, truth, clock_bias_m: Array, clock_drift_mps: Array
                     ) -> tuple[Array, npt.NDArray[np.bool_]]:
        """True states at the truth's samples, and which components are known.

        Parameters
        ----------
        truth : railnav.simulation.truth.Truth
            (K samples).
        clock_bias_m, clock_drift_mps : ndarray, shape (K,)
            True receiver clock at those samples.

        Returns
        -------
        x_true : ndarray, shape (K, n)
            Unknown components (IMU biases) are 0.
        known : ndarray of bool, shape (n,)
        """
        known_values = {"yaw": truth.yaw, "pitch": truth.pitch, "roll": truth.roll,
                        "s": truth.s, "v": truth.v, "clock_bias": clock_bias_m,
                        "clock_drift": clock_drift_mps}
        known_values.update(mount_truth(truth, np.size(truth.s)))
        return states_from_values(self.layout, known_values, np.size(truth.s))

    # -- outputs ---------------------------------------------------------------------------
    def estimates(self, x: Array, P_packed: Array) -> dict[str, Array]:
        """Estimate columns (`railnav.filters.estimate_columns.track_estimates`) of stored
        states."""
        P = unpack_sym(P_packed)
        var = np.diagonal(P, axis1=1, axis2=2)
        return track_estimates(self.track, self.layout, x, var)
