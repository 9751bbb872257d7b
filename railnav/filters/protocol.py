"""What a filter object is (`Filter`), and the one registry of filter kinds (`FILTERS`).

A *filter object* holds one filter's models and turns a trip's samples and GNSS epochs
into what the engine (`ekf.CdFilter`) consumes; the chunk loop that drives it is
`railnav.navigation.loop`. Every filter kind railnav runs is one `FilterKind` entry in
`FILTERS`: the command line's ``--filter`` choices, `railnav.config.NavigatorConfig`'s
check, streaming and the network navigator all read this table. Adding a filter kind means
adding one module with a class that satisfies `Filter`, and one entry here.

Time: ``t`` and ``time_s`` are seconds from the trip start.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from railnav.errors import ConfigError

__all__ = ["Filter", "FilterKind", "FILTERS", "FILTER_KINDS", "filter_kind", "make_filter"]

Array = npt.NDArray[np.float64]


@runtime_checkable
class Filter(Protocol):
    """The interface of a filter object (`railnav.filters.constrained.ConstrainedFilter`
    is the reference implementation).

    Attributes
    ----------
    layout : ekf.StateLayout
        Names and positions of the state.
    process : ekf.CdModel
        The continuous process model the engine propagates.
    q_c : ndarray
        Its white-noise spectral densities.
    track : trackmodel.Track
        The track of the run (the unconstrained filter uses it for its initial attitude and
        the outputs only).
    """

    layout: Any
    process: Any
    q_c: Array
    track: Any

    def inputs(self, t: Array, u: Array, x_prev: Array, P_prev: Array,
               t_prev: float) -> tuple[Array, Array, Array | None]:
        """The engine inputs ``(u, p, r_c)`` of the samples ``t`` that follow the state
        ``x_prev`` (covariance ``P_prev``) at ``t_prev``: inputs, per-step parameters and
        continuous-measurement noise densities (None: no continuous measurement)."""

    def observations(self, index: int, x: Array, P: Array) -> Any:
        """The GNSS rows (list of `ekf.Observation`, or `ekf.EpochRows`) of epoch `index`
        at the prior ``(x, P)``."""

    def estimates(self, x: Array, P_packed: Array) -> dict[str, Array]:
        """Output columns (`railnav.filters.estimate_columns.ESTIMATE_COLUMNS` first,
        `railnav.filters.estimate_columns.estimate_columns`) of stored states and packed
        covariances."""

    def initial_covariance(self, *, sigma_s_m: float, sigma_v_mps: float) -> Array:
        """The initial covariance, given the σ of ``s`` (m) and ``v`` (m/s)."""

    def initial_from_fix(self, fix: Any, *, restart: bool = False) -> tuple[Array, Array]:
        """``(x0, P0)`` from a GNSS fix (`railnav.navigation.initialization.GnssFix`);
        `restart` (a divergence monitor's): with the fix's own σ, not the configured start's
        (`railnav.filters.common.start_on_track`)."""

    def truth_states(self, truth: Any, clock_bias_m: Array,
                     clock_drift_mps: Array) -> tuple[Array, npt.NDArray[np.bool_]]:
        """The true states of a simulated trip in this layout, and which components the
        simulation knows (`railnav.navigation.initialization.initial_from_truth`)."""


@dataclass(frozen=True)
class FilterKind:
    """One kind of filter railnav can run.

    Attributes
    ----------
    name : str
        The ``--filter`` / `NavigatorConfig.filter` value.
    module, class_name : str
        Where the `Filter` class lives (imported when the first filter of the kind is
        built, so that choosing among kinds imports no model).
    needs_imu : bool
        The filter propagates IMU samples (else it runs on a time grid of its own).
    streams : bool
        It can run in streaming mode (`railnav.navigation.streaming`).
    banks : bool
        It can run as a hypothesis of the network navigator on observations
        (`railnav.navigation.network_navigator`, several tracks): it screens each
        epoch's rows and keeps their innovations (``screen.last``).
    fixes : bool
        It takes GNSS position fixes (`railnav.filters.fix_rows`): its class accepts
        ``fixes`` and ``schedule``.
    summary : str
        One line for help texts.
    track_sensors : bool
        It takes odometer readings, balise passages (`railnav.filters.sensor_rows`: its
        class accepts ``odometer`` and ``balises``) and sensor lever arms
        (`railnav.filters.track_frame.LeverArms`).
    noise_scale : bool
        It scales its GNSS observation rows' σ by the adaptive noise scale
        (`railnav.filters.noise_scale`, ``NavigatorConfig.noise_scale``).
    """

    name: str
    module: str
    class_name: str
    needs_imu: bool
    streams: bool
    banks: bool
    fixes: bool
    summary: str
    track_sensors: bool = False
    noise_scale: bool = False


#: Every filter kind, by name, in the order the help lists them.
FILTERS: dict[str, FilterKind] = {k.name: k for k in (
    FilterKind("constrained", "railnav.filters.constrained", "ConstrainedFilter",
               needs_imu=True, streams=True, banks=True, fixes=True,
               summary="track-constrained tightly coupled INS/GNSS (the 2017 paper's)",
               track_sensors=True, noise_scale=True),
    FilterKind("unconstrained", "railnav.filters.unconstrained", "UnconstrainedFilter",
               needs_imu=True, streams=True, banks=False, fixes=False,
               summary="unconstrained 9-state tightly coupled INS/GNSS (baseline)"),
    FilterKind("gnss-only", "railnav.filters.gnss_only", "GnssOnlyFilter",
               needs_imu=False, streams=False, banks=False, fixes=True,
               summary="GNSS-only on the track: [s, v, clock], no IMU", track_sensors=True,
               noise_scale=True),
)}

#: The names of `FILTERS`.
FILTER_KINDS: tuple[str, ...] = tuple(FILTERS)


def filter_kind(name: str) -> FilterKind:
    """The registry entry of filter `name`.

    Raises
    ------
    ConfigError
        For a name that is not in `FILTERS`.
    """
    try:
        return FILTERS[name]
    except (KeyError, TypeError):
        raise ConfigError(f"filter must be one of {', '.join(FILTER_KINDS)}, got "
                          f"{name!r}") from None


def make_filter(track, config, gnss, *, fixes=None, schedule=None, odometer=None,
                balises=None, body=None) -> Filter:
    """Build the filter object of ``config.filter``.

    Parameters
    ----------
    track : trackmodel.Track
    config : railnav.config.NavigatorConfig
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
        The trip's GNSS epochs (anything with ``prepare(index, r_guess_e)``); None when
        the filter will not see GNSS rows (or to build it only for its layout).
    fixes : railnav.filters.fix_epochs.FixEpochs, optional
        The trip's GNSS position fixes.
    schedule : railnav.filters.fix_epochs.EpochSchedule, optional
        The epochs ``observations(index, ...)`` is called with (GNSS epochs, fixes and the
        other streams merged); default: the GNSS epochs in order.
    odometer, balises : optional
        Odometer readings and balise passages (`railnav.filters.sensor_rows`).
    body : dict, optional
        The constrained filter's attitude and standstill streams
        (`railnav.filters.body_rows.body_stream_epochs`; it refuses them for other filters).

    Raises
    ------
    ConfigError
        Fixes, odometer, balises or lever arms for a filter kind that takes none.
    """
    kind = filter_kind(config.filter)
    cls = getattr(importlib.import_module(kind.module), kind.class_name)
    sensors = {k: v for k, v in (("odometer", odometer), ("balises", balises)) if v is not None}
    lever = getattr(config, "lever_arms", None)
    if (sensors or (lever is not None and lever != type(lever)())) and not kind.track_sensors:
        takes = " or ".join(k.name for k in FILTERS.values() if k.track_sensors)
        what = ", ".join(sensors) or "lever arms"
        raise ConfigError(f"the {kind.name} filter takes no {what} (the {takes} filters do)")
    if body:
        sensors["body"] = body
    if sensors:
        return cls(track, config, gnss, fixes=fixes, schedule=schedule, **sensors)
    if fixes is None and schedule is None:
        return cls(track, config, gnss)
    if not kind.fixes:
        takes = " or ".join(k.name for k in FILTERS.values() if k.fixes)
        raise ConfigError(f"the {kind.name} filter takes no GNSS fixes (the {takes} "
                          "filters do)")
    return cls(track, config, gnss, fixes=fixes, schedule=schedule)
