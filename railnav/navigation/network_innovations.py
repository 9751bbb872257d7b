"""The ``innovations.csv`` table of a network run (`railnav.navigation.network_result`).

`NetworkRecorder` keeps, at each screened epoch, the most probable hypothesis's fault
screen record (`railnav.filters.fault_detection.EpochScreen`) and its filter's noise
scale (`noise_factors`); `innovation_frame` makes the table of them, in the single-track
runs' columns (`railnav.navigation.result`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from railnav.filters.common import ROW_KINDS
from railnav.filters.noise_scale import row_scales

__all__ = ["innovation_frame", "noise_factors"]


def noise_factors(filt) -> tuple[float, ...]:
    """The noise scale's σ factors of `filt`'s latest epoch (its ``noise_scale.history``,
    `railnav.filters.noise_scale`), NaN without."""
    history = getattr(getattr(filt, "noise_scale", None), "history", None)
    return history[-1] if history else (np.nan,) * len(ROW_KINDS)


def innovation_frame(epochs: list, start_gps_time_s: float, factors: list
                     ) -> pd.DataFrame:
    """``innovations.csv`` of the screened epochs ``(EpochScreen, time_s)``
    (`railnav.navigation.result`'s columns; ``accepted``: used by the update; `factors`:
    each epoch's noise scale, `noise_factors`)."""
    sizes = [e.innov.size for e, _ in epochs]
    t = np.repeat([tk for _, tk in epochs], sizes).astype(float)
    keys = [k.split("/", 1) for e, _ in epochs for k in e.keys]
    innov = np.concatenate([e.innov for e, _ in epochs]) if epochs else np.zeros(0)
    sigma = np.sqrt(np.concatenate([np.diag(e.S) for e, _ in epochs])) if epochs else \
        np.zeros(0)
    cat = (lambda f: np.concatenate([f(e) for e, _ in epochs])) if epochs else \
        (lambda f: np.zeros(0))
    epoch = np.repeat(np.arange(len(epochs)), sizes)
    kind = np.array([b for _, b in keys], dtype=object)
    return pd.DataFrame({
        "time_s": t, "gps_time_s": t + start_gps_time_s, "epoch": epoch,
        "sv": np.array([a for a, _ in keys], dtype=object), "kind": kind,
        "innovation": innov,
        "sigma": sigma, "nis": (innov / sigma) ** 2, "accepted": cat(lambda e: e.used),
        "status": cat(lambda e: e.status).astype(object),
        "fault_probability": cat(lambda e: e.fault_probability),
        "clock_jump_m": np.repeat([e.clock_jump_m for e, _ in epochs], sizes).astype(float),
        "noise_scale": row_scales(factors, epoch, kind)})
