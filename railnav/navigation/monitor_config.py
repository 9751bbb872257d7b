"""The divergence monitor's settings (`MonitorConfig`), one owner of their defaults: read by
`railnav.navigation.monitor.FilterMonitor` and `railnav.config.NavigatorConfig`."""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["MonitorConfig"]


@dataclass(frozen=True)
class MonitorConfig:
    """Windows and thresholds of `railnav.navigation.monitor.FilterMonitor` (its module
    docstring gives the tests).

    Parameters
    ----------
    enabled : bool
    window_epochs : int
        Epochs in each test's window.
    small_window_epochs : int
        Epochs of the lower-tail fix test (``p_fix_small``: disagreements too small,
        `railnav.navigation.small_disagreement`).
    min_epochs : int
        Epochs after a start or recovery before the status may be ``ok``.
    p_degraded, p_lost : float
        Tail probabilities below which a test flags ``degraded`` / ``lost``.
    recover : bool
        Re-initialise (or widen) when ``lost``; on by default (``railnav run
        --no-recover``: off). No ``lost`` epoch in `benchmarks/bench_consistency.py`'s ten
        simulated cases (``consistency.json``) nor on the urban drive
        (``real_pieces.json``); a filter that does get lost (a MEMS IMU told it is
        navigation grade) is restarted instead of ending 1 km off
        (`tests/railnav/commands/test_cli_attitude.py`). (It was off while fixes projected
        on the wrong pass of a ring said ``lost`` on 160 of 280 consistent epochs.)
    lost_rejected_share : float
        The rejected-row test says ``lost`` only when at least this share of the window's
        rows was rejected (fewer: the rows, not the prior, are bad: multipath).
    min_fix_sigma_m, min_fix_sigma_mps : float
        Floors of a fix's along-track σ of position and speed.
    """

    enabled: bool = True
    window_epochs: int = 10
    small_window_epochs: int = 30
    min_epochs: int = 3
    p_degraded: float = 1e-3
    p_lost: float = 1e-6
    recover: bool = True
    lost_rejected_share: float = 0.5
    min_fix_sigma_m: float = 1.0
    min_fix_sigma_mps: float = 0.05
