"""`railnav.spp_files`, the public function behind ``railnav spp``: called from Python
it gives what the command writes (``spp.csv`` read back), with the command's defaults
(read from its parser), and its default solution is the library's for those settings."""
from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import railnav
from railnav.cli import build_parser, main

DATA = Path(__file__).resolve().parents[3] / "data" / "gnss"
OBS = DATA / "rover_obs_1240.rnx"
NAV = DATA / "broadcast_nav.rnx"
BASE = DATA / "base_obs_1240.rnx"
REF = DATA / "reference_trajectory_1240.csv"
SP3 = DATA / "COD21340_1100_1430.sp3"
#: ``spp.csv`` floats are written to 12 significant digits (``%.12g``): read back, a value
#: is within half a unit of the 12th digit, at most 5e-12 of it; one unit as the bound.
CSV_RTOL = 1e-11
#: ``gps_time_s`` is written to the µs: read back within half of it, s.
CSV_TIME_ATOL_S = 0.5e-6
#: spp_files argument -> the ``railnav spp`` parser's destination of the same flag.
SHARED_ARGUMENTS = {"systems": "systems", "ionosphere": "ionosphere",
                    "elevation_mask_deg": "elevation_mask_deg", "raim": "raim",
                    "base": "base", "base_position": "base_position",
                    "max_age_s": "max_age_s", "smooth_window_s": "smooth_window_s",
                    "sp3": "sp3", "reference": "ref"}


def _parser_defaults():
    """The ``railnav spp`` namespace when only the two required files are given."""
    return build_parser(["spp"]).parse_args(["spp", "--obs", "O", "--nav", "N"])


def _read_spp_csv(path: Path) -> pd.DataFrame:
    """``spp.csv`` as written: an empty ``excluded_sv`` is the empty string, not NaN."""
    frame = pd.read_csv(path, dtype={"excluded_sv": str})
    return frame.assign(excluded_sv=frame["excluded_sv"].fillna(""))


@pytest.mark.parametrize("base", [None, BASE], ids=["single", "base"])
def test_function_gives_the_commands_spp_csv(tmp_path, capsys, base):
    cli = ["-q", "spp", "--obs", str(OBS), "--nav", str(NAV), "--ref", str(REF),
           "--out", str(tmp_path / "out")]
    assert main(cli + (["--base", str(base)] if base else [])) == 0
    printed = capsys.readouterr().out.splitlines()
    written = _read_spp_csv(tmp_path / "out" / "spp.csv")

    run = railnav.spp_files(OBS, NAV, base=base, reference=REF)
    frame = run.frame.reset_index(drop=True)
    assert list(frame.columns) == list(written.columns) and len(frame) == 180
    np.testing.assert_allclose(frame["gps_time_s"], written["gps_time_s"],
                               rtol=0, atol=CSV_TIME_ATOL_S)
    pd.testing.assert_frame_equal(frame.drop(columns="gps_time_s"),
                                  written.drop(columns="gps_time_s"),
                                  check_exact=False, rtol=CSV_RTOL, atol=0.0)
    # the command prints the function's summary and accuracy, then what it wrote
    assert printed[:-1] == run.lines() and printed[-1].endswith("spp.csv, spp.png")
    assert ("DGNSS (base base_obs_1240.rnx)" in printed[0]) == (base is not None)


def test_defaults_are_the_commands():
    """Every flag the function shares with ``railnav spp`` has the parser's default, the
    systems (railnav's DEFAULT_SYSTEMS, not gnss_obs.SppConfig's) included."""
    parsed = _parser_defaults()
    parameters = inspect.signature(railnav.spp_files).parameters
    for name, dest in SHARED_ARGUMENTS.items():
        default = getattr(parsed, dest)
        default = tuple(default) if isinstance(default, list) else default   # --sp3 [] / ()
        assert parameters[name].default == default, name
    assert parameters["systems"].default == parsed.systems


def test_default_run_is_the_library_solution_for_the_commands_systems():
    """``spp_files(obs, nav)`` equals `gnss_obs.solve_spp` called with the command's default
    systems spelled out (a second path: no augmentation, no railnav code); the library's
    own default (``SppConfig()``) is a different solution when its systems differ."""
    from gnss_obs import MeasurementConfig, SppConfig, read_rinex_nav, read_rinex_obs, solve_spp

    systems = _parser_defaults().systems
    obs, nav = read_rinex_obs(OBS), read_rinex_nav(NAV)
    expected = solve_spp(obs, nav, SppConfig(measurement=MeasurementConfig(systems=systems)))
    run = railnav.spp_files(OBS, NAV)
    pd.testing.assert_frame_equal(run.frame, expected.to_frame())
    assert run.config.measurement.systems == systems and run.errors is None
    assert run.accuracy() is None
    if SppConfig().measurement.systems != systems:
        library = solve_spp(obs, nav).to_frame()
        assert [c for c in library if c.startswith("clock_bias_")] != \
            [c for c in run.frame if c.startswith("clock_bias_")]


def test_write_without_plot(tmp_path):
    run = railnav.spp_files(OBS, NAV)
    assert run.write(tmp_path / "o", plot=False) == [tmp_path / "o" / "spp.csv"]
    assert not (tmp_path / "o" / "spp.png").exists()
    back = _read_spp_csv(tmp_path / "o" / "spp.csv")
    assert back["n_sat_used"].tolist() == run.frame["n_sat_used"].tolist()


def test_one_sp3_path_is_one_file_not_its_characters():
    """``sp3="x.sp3"`` is the file (a string is a sequence of its characters): the same
    solution as ``sp3=[path]``, and precise orbits move it from the broadcast one."""
    one = railnav.spp_files(OBS, NAV, sp3=str(SP3))
    pd.testing.assert_frame_equal(one.frame, railnav.spp_files(OBS, NAV, sp3=[SP3]).frame)
    assert one.sp3 == (str(SP3),) and "precise orbits (SP3)" in one.lines()[0]
    broadcast = railnav.spp_files(OBS, NAV).frame
    assert not one.frame["lat_deg"].equals(broadcast["lat_deg"])
