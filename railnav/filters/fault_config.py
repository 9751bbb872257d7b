"""The fault screen's settings (`FaultDetectionConfig`), one owner of their defaults: read
by `railnav.filters.fault_detection.RowScreen` and `railnav.config.NavigatorConfig`."""
from __future__ import annotations

from dataclasses import dataclass

from ekf.outliers import fault_threshold
from railnav.errors import ConfigError

__all__ = ["FaultDetectionConfig"]


@dataclass(frozen=True)
class FaultDetectionConfig:
    """Parameters of the fault detection and exclusion (`railnav.filters.fault_detection`).

    Parameters
    ----------
    fault_prior : float
        Prior probability that a row is a fault, per row and epoch, in (0, 1).
    fault_scale : float
        κ > 1: a fault's innovation spread relative to the normal one.
    decision_probability : float
        A row whose fault probability exceeds this is rejected, in (0, 1).
    exclusion_failures, exclusion_window : int
        A channel with this many failures within its last `exclusion_window` epochs is
        excluded (1 <= failures <= window).
    readmission_passes : int
        Consecutive passes (epochs of the channel) that re-admit an excluded channel, >= 1.
    clock_jump_false_alarm : float or None
        Per-epoch false-alarm probability of the clock-jump test, in (0, 1); None: no
        clock-jump test.
    clock_jump_sigma_factor : float
        The jump variance added to the clock bias is ``(factor · â)²``, > 0 (3: the
        update's prior on the jump is three times broader than the jump seen).
    drift_allowance, drift_threshold : float or None
        CUSUM allowance δ >= 0 and alarm threshold h > 0 of the drift test, in σ of the
        innovation; ``drift_threshold=None``: no drift test.
    """

    fault_prior: float = 0.01
    fault_scale: float = 10.0
    decision_probability: float = 0.5
    exclusion_failures: int = 3
    exclusion_window: int = 5
    readmission_passes: int = 10
    clock_jump_false_alarm: float | None = 1e-7
    clock_jump_sigma_factor: float = 3.0
    drift_allowance: float = 0.35
    drift_threshold: float | None = 9.0

    def __post_init__(self) -> None:
        for name in ("fault_prior", "decision_probability"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0.0 < value < 1.0):
                raise ConfigError(f"{name} must be in (0, 1), got {value!r}")
        if not (isinstance(self.fault_scale, (int, float)) and self.fault_scale > 1.0):
            raise ConfigError(f"fault_scale must be > 1, got {self.fault_scale!r}")
        counts = (self.exclusion_failures, self.exclusion_window, self.readmission_passes)
        if not all(isinstance(c, int) and c >= 1 for c in counts) or \
                self.exclusion_failures > self.exclusion_window:
            raise ConfigError("need integers 1 <= exclusion_failures <= exclusion_window and "
                              f"readmission_passes >= 1, got {counts}")
        alarm = self.clock_jump_false_alarm
        if alarm is not None and not (isinstance(alarm, (int, float)) and 0.0 < alarm < 1.0):
            raise ConfigError(f"clock_jump_false_alarm must be in (0, 1) or None, got {alarm!r}")
        if not (isinstance(self.clock_jump_sigma_factor, (int, float))
                and self.clock_jump_sigma_factor > 0):
            raise ConfigError(f"clock_jump_sigma_factor must be > 0, got "
                              f"{self.clock_jump_sigma_factor!r}")
        if not (isinstance(self.drift_allowance, (int, float)) and self.drift_allowance >= 0):
            raise ConfigError(f"drift_allowance must be >= 0, got {self.drift_allowance!r}")
        h = self.drift_threshold
        if h is not None and not (isinstance(h, (int, float)) and h > 0):
            raise ConfigError(f"drift_threshold must be > 0 or None, got {h!r}")

    @property
    def nis_threshold(self) -> float:
        """The normalized innovation squared above which a row is rejected."""
        return fault_threshold(prior=self.fault_prior, scale=self.fault_scale,
                               decision=self.decision_probability)
