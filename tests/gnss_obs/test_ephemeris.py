"""Ephemeris selection (validity, health, Galileo messages) and broadcast group delays."""
from __future__ import annotations

import numpy as np
import pytest

from gnss_obs.constants import WEEK_S
from gnss_obs.ephemeris import MAX_AGE_S, group_delay_s, satellite_states, select_ephemeris

T_1240 = 2134 * WEEK_S + 45_600.0  # 2020-11-29 12:40:00 GPST
#: GPS L1/L2 frequency ratio 154/120 = 77/60 (IS-GPS-200N §20.3.3.3.3.2: γ = (77/60)²).
GAMMA_GPS_L1_L2 = (77.0 / 60.0) ** 2
#: Galileo E1/E5b ratio 154/118 and E1/E5a ratio 154/115 (10.23 MHz multiples).
GAMMA_GAL_E1_E5B = (154.0 / 118.0) ** 2
GAMMA_GAL_E1_E5A = (154.0 / 115.0) ** 2
RTOL = 1e-12


def test_picks_nearest_reference_time(nav):
    """G05 has records with toe 12:00 and 14:00: 12:40 takes 12:00, 13:30 takes 14:00."""
    sel = select_ephemeris(nav.records, ["G05", "G05"], [T_1240, T_1240 + 3000.0])
    toe_sow = sel["toe_sow"].to_numpy()
    np.testing.assert_array_equal(toe_sow, [43_200.0, 50_400.0])


def test_accepts_a_record_issued_after_the_epoch(nav):
    """G15's only record has toe 14:00 (data README: issued after the first epoch); 12:40 is
    within the ±2 h fit half-interval, so it is used; 11:50 is not."""
    sel = select_ephemeris(nav.records, ["G15", "G15"], [T_1240, T_1240 - 3000.0])
    assert list(sel["ephemeris_ok"]) == [True, False]
    assert sel["toe_sow"].iloc[0] == 50_400.0


def test_skips_unhealthy_and_unknown(nav):
    records = dict(nav.records)
    g = records["G"].copy()
    g.loc[g["sv"] == "G05", "health"] = 1.0
    records["G"] = g
    sel = select_ephemeris(records, ["G05", "G99", "S20", "G07"], [T_1240] * 4)
    assert list(sel["ephemeris_ok"]) == [False, False, False, True]
    assert list(sel["sv"]) == ["G05", "G99", "S20", "G07"]
    assert select_ephemeris(records, ["G05"], [T_1240],
                            healthy_only=False)["ephemeris_ok"].all()


@pytest.mark.parametrize("system", ["G", "E", "C", "R"])  # no QZSS in the file
def test_validity_limit_per_system(nav, system):
    """A request exactly beyond the system's age limit from every record finds none."""
    recs = nav.records[system]
    sv = recs["sv"].iloc[0]
    ref = recs.loc[recs["sv"] == sv, "toc_gps_s" if system == "R" else "toe_gps_s"]
    last = ref.max()
    age = MAX_AGE_S[system]
    if system in ("G", "J"):
        fit = recs.loc[recs["sv"] == sv, "fit_interval_h"].max()
        age = 0.5 * fit * 3600.0 if fit > 0 else age
    sel = select_ephemeris(nav.records, [sv, sv], [last + age - 1.0, last + age + 1.0])
    assert list(sel["ephemeris_ok"]) == [True, False]


@pytest.mark.parametrize("message,bit", [("inav", 1 << 9), ("fnav", 1 << 8)])
def test_galileo_message_choice(nav, message, bit):
    """I/NAV records carry data-source bit 9 (clock for E5b,E1), F/NAV bit 8 (E5a,E1)."""
    sel = select_ephemeris(nav.records, ["E01", "E07", "E33"], [T_1240] * 3,
                           galileo_message=message)
    sources = sel["data_sources"].to_numpy().astype(int)
    assert np.all(sources & bit)


def test_group_delays_per_signal(nav):
    """IS-GPS-200N, Galileo OS SIS ICD §5.1.5 and BDS-SIS-ICD §5.2.4.10 relations."""
    sel = select_ephemeris(nav.records, ["G05"] * 3, [T_1240] * 3)
    tgd = sel["tgd_s"].iloc[0]
    g = group_delay_s(sel, [1, 2, 5])
    np.testing.assert_allclose(g[:2], [tgd, GAMMA_GPS_L1_L2 * tgd], rtol=RTOL)
    assert np.isnan(g[2])  # L5 needs the CNAV ISC, not in LNAV
    for message, column, gamma, band in (("inav", "bgd_e5b_e1_s", GAMMA_GAL_E1_E5B, 7),
                                         ("fnav", "bgd_e5a_e1_s", GAMMA_GAL_E1_E5A, 5)):
        sel = select_ephemeris(nav.records, ["E01"] * 2, [T_1240] * 2, galileo_message=message)
        bgd = sel[column].iloc[0]
        g = group_delay_s(sel, [1, band], galileo_message=message)
        np.testing.assert_allclose(g, [bgd, gamma * bgd], rtol=RTOL)
    sel = select_ephemeris(nav.records, ["C10"] * 4, [T_1240] * 4)
    g = group_delay_s(sel, [2, 7, 6, 1])
    np.testing.assert_allclose(g[:3], [sel["tgd1_s"].iloc[0], sel["tgd2_s"].iloc[0], 0.0])
    assert np.isnan(g[3])
    sel = select_ephemeris(nav.records, ["R07"], [T_1240])
    assert group_delay_s(sel, [1])[0] == 0.0


def test_states_are_nan_without_record(nav):
    sel = select_ephemeris(nav.records, ["G05", "G99"], [T_1240] * 2)
    s = satellite_states(sel, [T_1240] * 2)
    assert np.all(np.isfinite(s.r_e[0])) and np.all(np.isnan(s.r_e[1]))
    assert np.isnan(s.clock_s[1])


def test_rejects_unknown_galileo_message(nav):
    with pytest.raises(ValueError, match="galileo_message"):
        select_ephemeris(nav.records, ["E01"], [T_1240], galileo_message="cnav")
