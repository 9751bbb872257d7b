"""Single-point positioning settings (`SppConfig`): the one owner of the SPP's defaults,
read by `gnss_obs.spp.solve_spp` and the ``railnav spp`` command."""
from __future__ import annotations

from dataclasses import dataclass, field

from gnss_obs.errors import GnssError
from gnss_obs.measurements import MeasurementConfig

__all__ = ["SppConfig"]


@dataclass(frozen=True)
class SppConfig:
    """Single-point positioning settings.

    Parameters
    ----------
    measurement : MeasurementConfig
        Systems, signals, corrections and the σ model.
    elevation_mask_deg : float
        Satellites below this elevation are not used, deg.
    min_cn0_dbhz : float
        Signals weaker than this are not used, dB-Hz (0 = no gate).
    raim : bool
        Exclude faulty measurements (FDE); when False the χ² test only flags.
    p_false_alarm : float
        False-alarm probability of the χ² test per epoch.
    p_missed_detection : float
        Missed-detection probability for the protection levels.
    max_exclusions : int
        Largest number of satellites excluded per epoch (pseudorange and Doppler each).
    huber_k : float or None
        Huber M-estimation threshold in standard deviations for both solutions
        (`gnss_obs.raim.huber_wls`); None = plain weighted least squares.
    max_iter : int
        Gauss-Newton iteration limit.
    tol_m : float
        Convergence threshold on the position update, m.
    max_gap_s : float
        Largest time since the previous fix for using it as the initial guess, s.
    velocity : bool
        Estimate velocity and clock drift from Doppler.
    """

    measurement: MeasurementConfig = field(default_factory=MeasurementConfig)
    elevation_mask_deg: float = 10.0
    min_cn0_dbhz: float = 0.0
    raim: bool = True
    p_false_alarm: float = 1e-3
    p_missed_detection: float = 1e-3
    max_exclusions: int = 4
    huber_k: float | None = 1.5
    max_iter: int = 20
    tol_m: float = 1e-3
    max_gap_s: float = 60.0
    velocity: bool = True

    def __post_init__(self) -> None:
        if not (-90.0 <= self.elevation_mask_deg < 90.0):
            raise GnssError(f"elevation_mask_deg must be in [-90, 90), got "
                            f"{self.elevation_mask_deg!r}")
        for name in ("p_false_alarm", "p_missed_detection"):
            p = getattr(self, name)
            if not (0.0 < p < 1.0):
                raise GnssError(f"{name} must be in (0, 1), got {p!r}")
        if self.max_exclusions < 0 or self.max_iter < 1:
            raise GnssError("max_exclusions must be >= 0 and max_iter >= 1")
        if not (self.tol_m > 0 and self.max_gap_s >= 0):
            raise GnssError("tol_m must be > 0 and max_gap_s >= 0")
        if self.huber_k is not None and not (self.huber_k > 0):
            raise GnssError(f"huber_k must be > 0 or None, got {self.huber_k!r}")
