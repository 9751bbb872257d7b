"""Code-differential corrections, carrier smoothing and precise orbits (issue 16).

References: closed forms (a Hatch average of noisy code on a noiseless carrier is the
running mean of the code noise; a base at its true position has zero corrections when
its code is the model), the RINEX cycle-slip indicators, the shipped SP3 product against
`Sp3.interpolate`, and the post-processed reference trajectory of the real drive.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gnss_obs.constants import SPEED_OF_LIGHT_MPS
from gnss_obs.dgps import DgpsConfig, apply_corrections, augment, base_corrections
from gnss_obs.errors import GnssError
from gnss_obs.measurements import MeasurementConfig
from gnss_obs.precise import PreciseOrbits
from gnss_obs.rinex_obs import read_rinex_obs
from gnss_obs.smoothing import SmoothingConfig, hatch_filter, smooth_observations
from gnss_obs.spp import SppConfig, solve_spp

GNSS_DATA = Path(__file__).resolve().parents[2] / "data" / "gnss"

#: Interpolation agreement of two implementations of the same Lagrange formula, m.
SAME_FORMULA_M = 1e-6


@pytest.fixture(scope="module")
def base_obs():
    return read_rinex_obs(GNSS_DATA / "base_obs_1240.rnx")


def test_hatch_is_the_running_mean_of_code_noise_on_a_clean_carrier():
    """With L = ρ exactly (no slips) and P = ρ + e, the Hatch output for k ≤ N is ρ_k +
    mean(e_1..e_k), then an exponential average with gain 1/N (closed form)."""
    rng = np.random.default_rng(16)
    k = np.arange(60.0)
    rho = 2.2e7 + 700.0 * k + 3.0 * k ** 2
    e = rng.normal(0.0, 2.0, k.size)
    s, n = hatch_filter(rho + e, rho + 123.4, np.zeros(k.size, bool), n_max=40)
    np.testing.assert_allclose(s[:40] - rho[:40], np.cumsum(e[:40]) / np.arange(1, 41),
                               atol=1e-6)
    expected = s[39] - rho[39]
    for j in range(40, 60):
        expected = e[j] / 40 + 39 / 40 * expected
        assert s[j] - rho[j] == pytest.approx(expected, abs=1e-6)
    assert n.tolist() == list(range(1, 41)) + [40] * 20


def test_hatch_restarts_on_a_flag_and_on_a_code_carrier_jump():
    k = np.arange(10.0)
    rho = 2.0e7 + 500.0 * k
    restart = np.zeros(10, bool)
    restart[4] = True
    carrier = rho.copy()
    carrier[7:] += 100.0                       # an undetected slip of ~500 cycles
    s, n = hatch_filter(rho, carrier, restart, n_max=100, max_code_carrier_m=30.0)
    assert n.tolist() == [1, 2, 3, 4, 1, 2, 3, 1, 2, 3]
    np.testing.assert_allclose(s, rho, atol=1e-6)


def _one_sv(obs, sv="G05", signal="1C"):
    t = obs.table
    return t[(t["sv"] == sv) & (t["signal"] == signal)].sort_values("gps_time_s")


def test_slips_restart_smoothing(rover_obs):
    """A 10-cycle jump inserted in G05's L1 carrier (no LLI) is caught by the geometry-free
    and Doppler tests; an LLI bit 0 (RINEX 3.04 §5.3: loss of lock) restarts alone."""
    cfg = SmoothingConfig(window_s=1000.0)
    clean = _one_sv(smooth_observations(rover_obs, cfg))
    table = rover_obs.table.copy()
    rows = _one_sv(rover_obs).index
    jump_at, lli_at = rows[60], rows[120]
    later = rows[rows.get_loc(jump_at):]
    table.loc[later, "carrier_cycles"] += 10.0
    table.loc[lli_at, "lli"] = 1
    slipped = _one_sv(smooth_observations(dataclasses.replace(rover_obs, table=table), cfg))
    raw = _one_sv(rover_obs)["pseudorange_m"].to_numpy()
    # both restarts give the raw code back at the restart epoch
    i_jump, i_lli = 60, 120
    assert slipped["pseudorange_m"].iloc[i_jump] == raw[i_jump]
    assert slipped["pseudorange_m"].iloc[i_lli] == raw[i_lli]
    assert clean["pseudorange_m"].iloc[i_jump] != raw[i_jump]
    # before the slip nothing changed
    np.testing.assert_array_equal(slipped["pseudorange_m"].iloc[:i_jump],
                                  clean["pseudorange_m"].iloc[:i_jump])


def test_base_corrections_vanish_for_code_that_is_the_model(base_obs, nav):
    """If the base's code is replaced by the model range at the base position plus a clock
    common to the system, every correction is zero (to the model's round-off)."""
    mc = MeasurementConfig(systems="G")
    r_base = base_obs.header.approx_position_e
    corr = base_corrections(base_obs, nav, mc, r_base_e=r_base)
    # rebuild the code: P_model = P - (correction + per-system median) -> corrections 0
    table = base_obs.table.copy()
    key = corr.set_index(["gps_time_s", "sv", "signal"])["correction_m"]
    idx = pd.MultiIndex.from_frame(table[["gps_time_s", "sv", "signal"]])
    shift = key.reindex(idx).to_numpy()
    table["pseudorange_m"] = table["pseudorange_m"] - np.nan_to_num(shift)
    again = base_corrections(dataclasses.replace(base_obs, table=table), nav, mc,
                             r_base_e=r_base)
    assert len(again) == len(corr)
    assert np.abs(again["correction_m"]).max() < 1e-3


def test_apply_corrections_age_limit():
    meas = pd.DataFrame({"gps_time_s": [10.0, 20.0, 45.0], "sv": ["G01"] * 3,
                         "signal": ["1C"] * 3, "pseudorange_m": [100.0, 100.0, 100.0]})
    corr = pd.DataFrame({"gps_time_s": [10.0], "sv": ["G01"], "signal": ["1C"],
                         "correction_m": [2.5], "elevation_deg": [40.0]})
    out = apply_corrections(meas, corr, max_age_s=30.0)
    assert out["gps_time_s"].tolist() == [10.0, 20.0]            # 35 s old: dropped
    assert out["pseudorange_m"].tolist() == [97.5, 97.5]
    assert out["correction_age_s"].tolist() == [0.0, 10.0]
    other = apply_corrections(meas.assign(signal="1W"), corr)     # no same-signal correction
    assert other.empty


def test_apply_corrections_matches_string_and_object_keys():
    """An iono-free table's combined signal names carry pandas' string dtype; the base's
    corrections may not (``railnav spp --base B --ionosphere iono-free`` stopped with
    pandas' MergeError): the same corrections apply whatever the keys' dtypes."""
    meas = pd.DataFrame({"gps_time_s": [10.0, 20.0], "sv": ["G01", "G02"],
                         "signal": ["1C", "1C"], "pseudorange_m": [100.0, 200.0]})
    corr = pd.DataFrame({"gps_time_s": [10.0, 10.0], "sv": ["G01", "G02"],
                         "signal": ["1C", "1C"], "correction_m": [2.5, -1.0],
                         "elevation_deg": [40.0, 50.0]})
    for rover, base in ((meas.astype({"signal": "string"}), corr),
                        (meas, corr.astype({"signal": "string", "sv": "string"}))):
        out = apply_corrections(rover, base)
        assert out["pseudorange_m"].tolist() == [97.5, 201.0]


def test_precise_orbits_agree_with_sp3_interpolate(cod_sp3):
    """Two implementations of the same Lagrange interpolation (Sp3.interpolate and
    PreciseOrbits.states), plus the relativistic term -2 r·v/c² (IGS convention)."""
    orbits = PreciseOrbits.from_sp3(cod_sp3)
    t = cod_sp3.table["gps_time_s"].min() + np.array([3000.0, 4567.8, 7777.7])
    for sv in ("G05", "E11", "R04"):
        r_ref, clk_ref = cod_sp3.interpolate(sv, t)
        st = orbits.states(np.full(3, sv), t)
        np.testing.assert_allclose(st.r_e, r_ref, atol=SAME_FORMULA_M)
        rel = -2 * np.einsum("ij,ij->i", st.r_e, st.v_e) / SPEED_OF_LIGHT_MPS ** 2
        np.testing.assert_allclose(st.clock_s, clk_ref + rel, rtol=0, atol=1e-15)
        # velocity: a ±1 s difference of Sp3.interpolate (O(dt²) ~ 1e-4 m/s at MEO)
        ahead, _ = cod_sp3.interpolate(sv, t + 1.0)
        behind, _ = cod_sp3.interpolate(sv, t - 1.0)
        np.testing.assert_allclose(st.v_e, (ahead - behind) / 2.0, atol=1e-3)
    assert np.isnan(orbits.states(np.array(["C05"]), t[:1]).r_e).all()


def _horizontal_rms(result, reference) -> float:
    ref = reference.set_index("gps_time_s")
    fixed = result.gps_time_s[np.isfinite(result.r_e[:, 0])]
    common = np.intersect1d(fixed, ref.index.to_numpy())
    sol = result.r_e[np.isin(result.gps_time_s, common)]
    truth = ref.loc[common, ["x_m", "y_m", "z_m"]].to_numpy()
    from trackmodel.earth import C_n_e, ecef_to_geodetic
    lat, lon, _ = ecef_to_geodetic(truth)
    enu = np.einsum("nji,nj->ni", C_n_e(lat, lon), sol - truth)
    return float(np.sqrt(np.mean(enu[:, 0] ** 2 + enu[:, 1] ** 2)))


def test_dgps_on_the_real_drive_beats_rtklib_dgps(rover_obs, base_obs, nav, reference):
    """The issue's target on the shared window: GPS code DGNSS horizontal RMS below
    RTKLIB 2.4.3 rnx2rtkp DGPS's 4.14 m (issue 16), against the post-processed reference;
    and the vertical error well below the single-point one (the base removes the
    ionosphere the broadcast model leaves: measured 6.7 m SPP against 2.9 m here)."""
    mc = MeasurementConfig(systems="G")
    cfg = SppConfig(measurement=mc)
    aug = augment(rover_obs, nav, mc, base_obs=base_obs)
    dgps = solve_spp(aug.obs, nav, cfg, corrections=aug.corrections)
    assert _horizontal_rms(dgps, reference) < 4.14
    spp = solve_spp(rover_obs, nav, cfg)
    ref = reference.set_index("gps_time_s")

    def up_rms(res):
        from trackmodel.earth import ecef_to_geodetic
        keep = np.isin(res.gps_time_s, ref.index) & np.isfinite(res.r_e[:, 0])
        h = ecef_to_geodetic(res.r_e[keep])[2]
        h_ref = ecef_to_geodetic(ref.loc[res.gps_time_s[keep], ["x_m", "y_m", "z_m"]]
                                 .to_numpy())[2]
        return float(np.sqrt(np.mean((h - h_ref) ** 2)))
    assert up_rms(dgps) < 0.6 * up_rms(spp)


def test_iono_free_dgps_on_the_real_drive(rover_obs, base_obs, nav, reference):
    """Dual-frequency code DGNSS (the iono-free combination at rover and base) on the
    shared window: every epoch with a correction solves, within RTKLIB 2.4.3 rnx2rtkp
    DGPS's 4.14 m horizontal RMS (issue 16's published figure, as above)."""
    mc = MeasurementConfig(systems="G", ionosphere="iono-free")
    aug = augment(rover_obs, nav, mc, base_obs=base_obs)
    dgps = solve_spp(aug.obs, nav, SppConfig(measurement=mc), corrections=aug.corrections)
    assert np.isfinite(dgps.r_e[:, 0]).sum() > 0.9 * len(dgps.gps_time_s)
    assert _horizontal_rms(dgps, reference) < 4.14


def test_augment_rejects_a_base_position_without_base(rover_obs, nav):
    with pytest.raises(GnssError, match="without a base"):
        augment(rover_obs, nav, MeasurementConfig(systems="G"),
                base_lat_lon_h=(41.5, 2.4, 80.0))
    with pytest.raises(GnssError, match="max_age_s"):
        DgpsConfig(max_age_s=-1.0)
