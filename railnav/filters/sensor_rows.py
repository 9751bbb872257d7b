"""The track filters' rows of the railway sensors: odometer and balises, at an epoch.

The constrained and GNSS-only filters take, beside GNSS rows and fixes, the rows of an
odometer (`railnav.filters.odometer_rows`) and of balise passages
(`railnav.filters.balise_rows`), each a stream of the run's `EpochSchedule`
(`SENSOR_STREAMS`). This module owns what the filters share about them:

* `sensor_states`, `sensor_densities`: the optional state block they add (the odometer's
  scale factor ``odo_scale``, with `OdometerConfig.estimate_scale`) and its random-walk
  density (its prior variance: `railnav.filters.ins_clock_model.initial_variances`);
* `SensorRows`: the rows of an epoch, with their screen modes (the odometer one *channel*
  of the fault screen, so that a slip episode is excluded as a whole; balises ``row`` by
  row), for `railnav.filters.fix_rows.stack_epoch_rows`;
* `slip_episodes`, `sensor_statistics`: what the screen made of them, for ``summary.json``
  (`railnav.navigation.result.NavigationResult.statistics`).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.filters.balise_rows import BALISE_ROW_KIND, BaliseRowBuilder
from railnav.filters.odometer_rows import (
    ODOMETER_ROW_KINDS,
    SCALE_STATE,
    OdometerRowBuilder,
)

__all__ = ["SENSOR_STREAMS", "sensor_states", "sensor_densities", "SensorRows", "slip_episodes", "sensor_statistics", "EPISODE_GAP_S"]

Array = npt.NDArray[np.float64]

#: The schedule's streams of the railway sensors.
SENSOR_STREAMS = ("odometer", "balises")
#: Screen mode of each stream's rows (`railnav.filters.fault_detection.SCREEN_MODES`).
_MODES = {"odometer": "channel", "balises": "row"}
#: Odometer rows not used within this of each other are one slip/slide episode, s.
EPISODE_GAP_S = 2.0


def sensor_states(config, odometer) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """The state blocks the sensors add: ``(("odometer", ("odo_scale",)),)`` with odometer
    readings and ``config.odometer_model.estimate_scale``, else none."""
    if odometer is None or not config.odometer_model.estimate_scale:
        return ()
    return (("odometer", (SCALE_STATE,)),)


def sensor_densities(config, blocks) -> tuple[float, ...]:
    """Random-walk spectral densities of the states of `blocks` (1/s for the scale)."""
    walk = config.odometer_model.scale_walk_per_rts
    return tuple(walk ** 2 for _, names in blocks for _ in names)


class SensorRows:
    """The odometer and balise rows of a filter (module docstring).

    Parameters
    ----------
    layout : ekf.StateLayout
    config : railnav.NavigatorConfig
        Its ``odometer_model`` and the balise reader's lever arm.
    odometer : railnav.filters.odometer_epochs.OdometerEpochs, optional
    balises : railnav.filters.balise_rows.BaliseEpochs, optional
    """

    #: Screen mode of each stream's rows.
    modes = _MODES

    def __init__(self, layout, config, *, odometer=None, balises=None) -> None:
        self.builders = {}
        if odometer is not None:
            self.builders["odometer"] = OdometerRowBuilder(layout, odometer, config.odometer_model)
        if balises is not None:
            self.builders["balises"] = BaliseRowBuilder(
                layout, balises, config.lever_arms.balise_reader_forward_m)

    def __bool__(self) -> bool:
        return bool(self.builders)

    def parts(self, schedule, index: int, x: Array, P: Array) -> list:
        """The rows of epoch `index`: ``[((observations, sv, kind), mode), ...]``."""
        out = []
        for stream, builder in self.builders.items():
            k = schedule.index(stream, index)
            part = None if k < 0 else builder.observations(k, x, P)
            if part is not None:
                out.append((part, self.modes[stream]))
        return out

    @property
    def skipped(self) -> int:
        """Odometer readings skipped (direction unknown)."""
        odo = self.builders.get("odometer")
        return 0 if odo is None else odo.skipped


def slip_episodes(innovations: pd.DataFrame, *, gap_s: float = EPISODE_GAP_S) -> list[dict]:
    """Odometer speed rows the screen did not use, grouped into episodes.

    Returns
    -------
    list of dict
        ``start_s, end_s`` (s from the trip start), ``rows``, ``kind`` (``slip``: the wheel
        read faster than the vehicle, mean innovation > 0; ``slide``: slower) and
        ``max_excess_mps`` (the largest |innovation|).
    """
    rows = innovations[(innovations["kind"] == ODOMETER_ROW_KINDS[0])
                       & (innovations["status"] != "used")]
    if rows.empty:
        return []
    t, nu = rows["time_s"].to_numpy(), rows["innovation"].to_numpy()
    starts = np.flatnonzero(np.concatenate([[True], np.diff(t) > gap_s]))
    ends = np.concatenate([starts[1:], [t.size]])
    return [{"start_s": float(t[a]), "end_s": float(t[b - 1]), "rows": int(b - a),
             "kind": "slip" if nu[a:b].mean() > 0 else "slide",
             "max_excess_mps": float(np.abs(nu[a:b]).max())} for a, b in zip(starts, ends)]


def sensor_statistics(innovations: pd.DataFrame) -> dict:
    """``summary.json`` statistics of the odometer and balise rows (empty without them)."""
    out: dict = {}
    if not len(innovations):
        return out
    odo = innovations[innovations["kind"].isin(ODOMETER_ROW_KINDS)]
    if len(odo):
        speed = odo[odo["kind"] == ODOMETER_ROW_KINDS[0]]
        zero = odo[odo["kind"] == ODOMETER_ROW_KINDS[1]]
        out["odometer"] = {
            "rows": int(len(odo)), "zero_speed_rows": int(len(zero)),
            "rows_rejected": int((odo["status"] == "rejected").sum()),
            "rows_excluded": int((odo["status"] == "excluded").sum()),
            "nis_used_mean": _mean(speed.loc[speed["accepted"], "nis"]),
            "zero_speed_nis_mean": _mean(zero.loc[zero["accepted"], "nis"]),
            "slip_episodes": slip_episodes(innovations)}
    bal = innovations[innovations["kind"] == BALISE_ROW_KIND]
    if len(bal):
        out["balises"] = {"rows": int(len(bal)), "rows_rejected": int((~bal["accepted"]).sum()),
                          "nis_used_mean": _mean(bal.loc[bal["accepted"], "nis"])}
    return out


def _mean(values) -> float | None:
    return float(values.mean()) if len(values) else None
