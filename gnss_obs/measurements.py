"""Which observations enter the models: signal choice, ionosphere-free combination, Doppler.

`MeasurementConfig` is the one description of the GNSS measurements shared by the SPP
(`gnss_obs.spp`), the navigator and the simulator: systems, single or dual frequency,
corrections and the error model. `select_measurements` reduces an observation table
(`read_rinex_obs`) to one row per epoch × satellite:

* the signal is the first of the system's preference list (`PRIMARY_SIGNALS`) that has a
  pseudorange; with ``ionosphere="iono-free"`` a second signal (`SECONDARY_SIGNALS`) is
  required and the pseudorange is the ionosphere-free combination
  ``(f1² P1 - f2² P2) / (f1² - f2²)``;
* the range rate is ``-λ D`` of the primary signal's Doppler ``D`` (Hz), NaN when absent
  (ARCHITECTURE.md, GNSS).

The Galileo pair E1/E5b is used with the I/NAV clock (referenced to E1/E5b), so that both
single-frequency E1 and the E1/E5b combination take the same message.
"""
from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from gnss_obs.constants import SPEED_OF_LIGHT_MPS, carrier_frequency_hz
from gnss_obs.corrections import IONOSPHERE_MODELS
from gnss_obs.ephemeris import GALILEO_MESSAGES
from gnss_obs.errors import GnssError

__all__ = ["MeasurementConfig", "SIGMA_MODELS", "URBAN_CODE_SIGMAS",
           "PRIMARY_SIGNALS", "SECONDARY_SIGNALS", "IONOSPHERE_MODELS",
           "MEASUREMENT_COLUMNS", "select_measurements", "glonass_channels"]

log = logging.getLogger(__name__)

#: Signal preference per system for single-frequency use (RINEX 3 band + attribute).
PRIMARY_SIGNALS: dict[str, tuple[str, ...]] = {
    "G": ("1C", "1W", "1X"), "E": ("1C", "1X", "1B"), "C": ("2I", "2X"),
    "R": ("1C", "1P"), "J": ("1C", "1X"),
}
#: Second signal of the ionosphere-free pair per system (GPS L2 P(Y)/L2C, Galileo E5b,
#: BeiDou B2I, GLONASS L2, QZSS L2C).
SECONDARY_SIGNALS: dict[str, tuple[str, ...]] = {
    "G": ("2W", "2L", "2X", "2S"), "E": ("7Q", "7X", "7I"), "C": ("7I", "7X"),
    "R": ("2C", "2P"), "J": ("2L", "2X", "2S"),
}

#: Pseudorange σ models of `MeasurementConfig.sigma_model`.
SIGMA_MODELS = ("product", "additive")

#: The ``additive`` pseudorange σ model's constants for a car-mounted receiver in city
#: streets (`MeasurementConfig` fields; ``cn0_ref_dbhz`` 45, the default). Calibrated by
#: `benchmarks/bench_pseudorange_sigma.py` on the shared urban drive (Septentrio
#: mosaic-X5, GPS L1 C/A + Galileo E1, Klobuchar, broadcast orbits): the pseudorange
#: residuals at the PPK reference trajectory (`gnss_obs.residuals`) of 12:43:00 GPST to
#: the U-turn (SoW 45966), elevations ≥ 10°, 2443 measurements, fitted by non-negative
#: least squares of the squared residuals on ``[1, 1/sin²el, 10^(max(45 - C/N0, 0)/10)]``
#: (clipping the residuals at 20 or 30 m moves the constants by at most 0.08 m).
#: Normalized residual RMS on the pieces left out: 1.00 (12:40:00-12:42:59, the shipped
#: excerpt; the old ``product`` default: 0.83), 1.00 (the U-turn and leg 2; old: 1.58);
#: by C/N0 class < 35 / 35-45 / ≥ 45 dB-Hz: 1.55 / 0.74 / 0.58 and 0.77 / 1.09 / 0.93
#: (old: 0.46 / 0.77 / 1.19 and 0.28 / 1.33 / 2.17). The static base station 15 km away
#: (open sky, geodetic antenna, C/N0 ≥ 40) sees 0.49: its errors are the orbit, clock and
#: atmosphere floor (1.5 m RMS) without the streets' multipath, so the model is
#: pessimistic there (`benchmarks/results/pseudorange_sigma.json`).
#:
#: Opt-in, not the default: honest per-measurement σ did not make the filters honest. In
#: the gnss-only filter on the drive's 9 pieces (`benchmarks/bench_real_pieces.py
#: --urban-sigmas`, SPP with the default) epochs beyond 3σ_s went from 101 to 123 of 952
#: and filter/piece pairs worse than SPP from 3 to 5 of 18; as SPP weights, its horizontal
#: RMS went from 3.14 to 3.80 m. The weak signals' errors are heavy-tailed (NLOS), and the
#: default's steep C/N0 down-weighting protects the solutions; what σ_s misses is how long
#: the errors last (`pseudorange_autocorrelation` in the JSON: 0.93 at 60 s on the U-turn).
URBAN_CODE_SIGMAS = {"sigma_model": "additive", "sigma_pr_m": 2.34,
                     "sigma_pr_elevation_m": 1.07, "sigma_pr_cn0_m": 0.35}

#: Columns of the `select_measurements` table.
MEASUREMENT_COLUMNS = ["gps_time_s", "sv", "system", "prn", "signal", "band", "frequency_hz",
                       "band2", "frequency2_hz", "pseudorange_m", "range_rate_mps",
                       "cn0_dbhz"]


@dataclass(frozen=True)
class MeasurementConfig:
    """GNSS measurement selection, corrections and error model.

    Parameters
    ----------
    systems : str
        System letters to use, e.g. ``"G"`` or ``"GE"`` (subset of ``"GERCJ"``).
    ionosphere : {"klobuchar", "iono-free", "none"}
        Broadcast Klobuchar model scaled to each frequency, the dual-frequency combination
        (no model), or no correction.
    troposphere : bool
        Apply the Saastamoinen + Niell delay (`gnss_obs.corrections`).
    sigma_model : {"product", "additive"}
        Pseudorange σ model (`gnss_obs.epoch.measurement_sigmas`): ``product``
        ``σ_pr / sin(el) · 10^(max(cn0_ref - C/N0, 0) / 20)``; ``additive``, the
        RTKLIB form ``σ² = σ_pr² + σ_el² / sin²(el) + σ_cn0² · 10^(max(cn0_ref - C/N0, 0)
        / 10)`` (`URBAN_CODE_SIGMAS` for its constants calibrated on real urban data). The
        range rate keeps the product form under both.
    sigma_pr_m : float
        Pseudorange standard deviation at zenith and high C/N0 (``product``), or the
        constant term (``additive``), m.
    sigma_pr_floor_m : float
        ``product``: a constant term added in quadrature, ``σ² = σ_floor² + σ_product²``
        (0: the product alone), m.
    sigma_pr_elevation_m : float
        ``additive``: the term divided by ``sin(el)``, m.
    sigma_pr_cn0_m : float
        ``additive``: the term grown by the C/N0 deficit, m.
    sigma_rr_mps : float
        Range-rate (Doppler) standard deviation at zenith and high C/N0, m/s.
    elevation_weighting : bool
        Scale the standard deviations by ``1 / sin(elevation)`` (``additive``: keep the
        elevation term; False drops it).
    cn0_ref_dbhz : float
        C/N0 at and above which no C/N0 penalty applies; below it the standard deviation
        grows by ``10^((cn0_ref - C/N0) / 20)`` (the amplitude ratio; ``additive``: its
        term's variance by ``10^((cn0_ref - C/N0) / 10)``). NaN disables it (and drops
        the ``additive`` C/N0 term).
    galileo_message : {"inav", "fnav"}
        Galileo navigation message whose clock is used (see `gnss_obs.ephemeris`).
    """

    systems: str = "GE"
    ionosphere: str = "klobuchar"
    troposphere: bool = True
    sigma_model: str = "product"
    sigma_pr_m: float = 1.0
    sigma_pr_floor_m: float = 0.0
    sigma_pr_elevation_m: float = 0.0
    sigma_pr_cn0_m: float = 0.0
    sigma_rr_mps: float = 0.05
    elevation_weighting: bool = True
    cn0_ref_dbhz: float = 45.0
    galileo_message: str = "inav"

    def __post_init__(self) -> None:
        if not self.systems or set(self.systems) - set(PRIMARY_SIGNALS) or \
                len(set(self.systems)) != len(self.systems):
            raise GnssError(f"systems must be distinct letters of {''.join(PRIMARY_SIGNALS)}, "
                            f"got {self.systems!r}")
        if self.ionosphere not in IONOSPHERE_MODELS:
            raise GnssError(f"ionosphere must be one of {IONOSPHERE_MODELS}, "
                            f"got {self.ionosphere!r}")
        if self.galileo_message not in GALILEO_MESSAGES:
            raise GnssError(f"galileo_message must be one of {sorted(GALILEO_MESSAGES)}")
        if self.sigma_model not in SIGMA_MODELS:
            raise GnssError(f"sigma_model must be one of {SIGMA_MODELS}, "
                            f"got {self.sigma_model!r}")
        for name in ("sigma_pr_m", "sigma_rr_mps"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise GnssError(f"{name} must be a finite number > 0, got {value!r}")
        for name in ("sigma_pr_floor_m", "sigma_pr_elevation_m", "sigma_pr_cn0_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise GnssError(f"{name} must be a finite number >= 0, got {value!r}")

    @property
    def iono_free(self) -> bool:
        """True when pseudoranges are dual-frequency ionosphere-free combinations."""
        return self.ionosphere == "iono-free"


def glonass_channels(obs_slots: Mapping[str, int], nav_records: Mapping[str, pd.DataFrame]
                     ) -> dict[str, int]:
    """GLONASS FDMA channel per satellite: observation header first, then nav records."""
    channels: dict[str, int] = {}
    glo = nav_records.get("R")
    if glo is not None and len(glo):
        for sv, k in zip(glo["sv"], glo["freq_channel"]):
            channels[str(sv)] = int(k)
    channels.update({str(k): int(v) for k, v in obs_slots.items()})
    return channels


def _best_signal(table: pd.DataFrame, preferences: Mapping[str, tuple[str, ...]],
                 systems: str) -> pd.DataFrame:
    """Per (epoch, satellite): the row of the most preferred signal with a pseudorange."""
    rank = np.full(len(table), np.inf)
    system = table["system"].to_numpy()
    signal = table["signal"].to_numpy()
    for s in systems:
        for k, code in enumerate(preferences.get(s, ())):
            rank[(system == s) & (signal == code)] = k
    ok = np.isfinite(rank) & np.isfinite(table["pseudorange_m"].to_numpy())
    rows = table.loc[ok].assign(_rank=rank[ok])
    rows = rows.sort_values(["gps_time_s", "sv", "_rank"], kind="stable")
    return rows.drop_duplicates(["gps_time_s", "sv"], keep="first")


def _frequencies(system: np.ndarray, band: np.ndarray, sv: np.ndarray,
                 channels: Mapping[str, int]) -> np.ndarray:
    """`carrier_frequency_hz` of each row (NaN where it has none), asked once per
    distinct signal (system, band and, for GLONASS, the satellite's channel)."""
    known: dict = {}
    out = []
    for s, b, name in zip(system.tolist(), band.tolist(), sv.tolist()):
        key = (s, b, channels.get(name))
        value = known.get(key)
        if value is None:
            try:
                value = carrier_frequency_hz(s, int(b), key[2])
            except KeyError:
                value = np.nan
            known[key] = value
        out.append(value)
    return np.array(out, dtype=float).reshape(np.shape(system))


def select_measurements(table: pd.DataFrame, config: MeasurementConfig, *,
                        glonass_channels: Mapping[str, int] | None = None) -> pd.DataFrame:
    """One measurement per epoch × satellite from an observation table.

    Parameters
    ----------
    table : pandas.DataFrame
        `RinexObs.table` (one row per epoch × satellite × signal).
    config : MeasurementConfig
    glonass_channels : mapping of str to int, optional
        GLONASS FDMA channel per satellite (`glonass_channels`); GLONASS satellites
        without one are dropped.

    Returns
    -------
    pandas.DataFrame
        `MEASUREMENT_COLUMNS`, sorted by (``gps_time_s``, ``sv``): the used signal and band
        (``band2``/``frequency2_hz`` the second band of an ionosphere-free pair, else 0/NaN),
        ``pseudorange_m`` (combined when ionosphere-free), ``range_rate_mps`` (``-λ D``,
        NaN without Doppler), ``cn0_dbhz`` of the primary signal.
    """
    channels = dict(glonass_channels or {})
    primary = _best_signal(table, PRIMARY_SIGNALS, config.systems)
    sv = primary["sv"].to_numpy()
    system = primary["system"].to_numpy()
    band = primary["band"].to_numpy()
    freq = _frequencies(system, band, sv, channels)
    out = pd.DataFrame({
        "gps_time_s": primary["gps_time_s"].to_numpy(), "sv": sv, "system": system,
        "prn": primary["prn"].to_numpy(), "signal": primary["signal"].to_numpy(),
        "band": band, "frequency_hz": freq, "band2": np.zeros(len(sv), dtype=np.int64),
        "frequency2_hz": np.full(len(sv), np.nan),
        "pseudorange_m": primary["pseudorange_m"].to_numpy(),
        "range_rate_mps": -SPEED_OF_LIGHT_MPS / freq * primary["doppler_hz"].to_numpy(),
        "cn0_dbhz": primary["cn0_dbhz"].to_numpy()})
    if config.iono_free:
        out = _combine_iono_free(out, _best_signal(table, SECONDARY_SIGNALS, config.systems),
                                 channels)
    out = out[np.isfinite(out["frequency_hz"].to_numpy())]
    return out.reset_index(drop=True)


def _combine_iono_free(out: pd.DataFrame, second: pd.DataFrame,
                       channels: Mapping[str, int]) -> pd.DataFrame:
    merged = out.merge(second[["gps_time_s", "sv", "band", "pseudorange_m"]],
                       on=["gps_time_s", "sv"], how="inner", suffixes=("", "_2"))
    f1 = merged["frequency_hz"].to_numpy()
    f2 = _frequencies(merged["system"].to_numpy(), merged["band_2"].to_numpy(),
                      merged["sv"].to_numpy(), channels)
    g1, g2 = f1 * f1, f2 * f2
    merged["pseudorange_m"] = (g1 * merged["pseudorange_m"] - g2 * merged["pseudorange_m_2"]) \
        / (g1 - g2)
    merged["band2"] = merged.pop("band_2").astype(np.int64)
    merged["frequency2_hz"] = f2
    dropped = len(out) - len(merged)
    if dropped:
        log.info("ionosphere-free: %d of %d measurements lack the second frequency",
                 dropped, len(out))
    return merged[MEASUREMENT_COLUMNS]
