"""Study configuration files: values, defaults from the scenario, located one-line errors.

References: the TOML texts written in the tests (and data/studies/tiny.toml, read back key
by key), the base scenario's own values for the defaults, and the line numbers of the
offending keys counted in those texts.
"""
from __future__ import annotations

import math
from dataclasses import replace

import pytest

from railnav.cli import main
from railnav.errors import ConfigError
from railnav.simulation.scenarios import get_scenario
from railnav.studies.config import StudyConfig
from railnav.studies.file import load_study_config, parse_study_config
from tests.conftest import DATA

TINY = DATA / "studies" / "tiny.toml"


def test_tiny_study_file_values_and_defaults():
    """Written keys as written; absent axes take the scenario's values."""
    config = load_study_config(TINY)
    paper = get_scenario("paper2017")
    assert (config.name, config.seed, config.replicates, config.duration_s) == ("tiny", 7, 2, 30.0)
    assert config.tracks == ("paper2017.csv",)
    assert config.imu_grades == ("paper2017", "tactical")
    assert config.filters == ("constrained", "unconstrained")
    assert config.outage_sets == (((10.0, 5.0),), ((10.0, 10.0),))
    assert config.speeds_mps == (paper.profile.max_speed_mps,)
    assert config.sigma_pseudorange_m == (paper.sigma_pseudorange_m,)
    assert config.sigma_range_rate_mps == (paper.sigma_range_rate_mps,)
    assert (config.systems, config.mode, config.chunk_runs) == ("G", "memory", 3)
    assert config.common_random_numbers is True
    assert config.track_path("paper2017.csv").name == "paper2017.csv"


def test_example_study_file_loads():
    config = load_study_config(DATA / "studies" / "outages.toml")
    assert config.scenario == "curvy"
    assert len(config.outage_sets) == 5 and config.replicates == 20


def test_explicit_outage_sets_and_scenario_outages(tmp_path):
    """``outages`` lists whole sets (an empty set is a run without outage); no outage key
    gives the scenario's own windows."""
    text = '[grid]\noutages = [[[100.0, 50.0], [500, 50]], []]\n'
    config = parse_study_config(text, path=tmp_path / "s.toml")
    assert config.outage_sets == (((100.0, 50.0), (500.0, 50.0)), ())
    plain = parse_study_config("[study]\nname = 'x'\n", path=tmp_path / "s.toml")
    assert plain.outage_sets == (get_scenario("paper2017").outages,)
    assert math.isclose(plain.duration_s, get_scenario("paper2017").duration_s)


def test_relative_track_path(tmp_path):
    """A track next to the configuration file is found there."""
    (tmp_path / "mine.csv").write_text((DATA / "tracks" / "paper2017.csv").read_text())
    config = parse_study_config('[grid]\ntrack = "mine.csv"\n', path=tmp_path / "s.toml")
    assert config.track_path("mine.csv") == tmp_path / "mine.csv"


BAD = [
    # (file text, line, key, words of the message)
    ("[study]\nname = 'x'\nreplicate = 3\n", 3, "study.replicate", "unknown key"),
    ("[grid]\nfilter = 'constrained'\n\nimu_grade = ['tactical', 'gold']\n", 4,
     "grid.imu_grade", "unknown IMU grade 'gold'"),
    ("[study]\nmode = 'streaming'\n[grid]\nfilter = ['constrained', 'gnss-only']\n", 4,
     "grid.filter", "in streaming mode"),
    ("[grid]\nspeed_mps = [20, -5]\n", 2, "grid.speed_mps", "> 0"),
    ("[study]\nseed = 1\nreplicates = 0\n", 3, "study.replicates", ">= 1"),
    ("[study]\nduration_s = 'long'\n", 2, "study.duration_s", "expected a number"),
    ("[study]\nname = 'x'\nseed = [1,\n", 3, None, "Invalid"),      # at the end
    ("[study]\nname = 'x'\nseed = 1 2\n[grid]\n", 3, None, "Expected newline"),
    ("[grids]\ntrack = 'x.csv'\n", 1, None, "unknown table [grids]"),
    ("[grid]\noutages = [[[1, 2]]]\noutage_start_s = 5\n", 2, "grid.outages", "not both"),
    ("[grid]\noutage_duration_s = [5, 10]\n", 1, None, "outage_start_s is missing"),
    ("[grid]\noutage_start_s = 5\noutage_duration_s = [5, 0]\n", 3,
     "grid.outage_duration_s", "duration_s > 0"),
    ("[grid]\noutages = [[1, 2]]\n", 2, "grid.outages", "list of [start_s, duration_s]"),
    ("[grid]\ntrack = ['nowhere.csv']\n", 2, "grid.track", "not found"),
    ("[grid]\nimu_grade = ['mems', 'mems']\n", 2, "grid.imu_grade", "repeated"),
    ("[study]\nsystems = 'GX'\n", 2, "study.systems", "systems"),
    ("[study]\nscenario = 'metro'\n", 2, "study.scenario", "unknown scenario"),
    ("[streaming]\nsegment_s = 0\n", 2, "streaming.segment_s", "> 0"),
]


@pytest.mark.parametrize("text, line, key, words", BAD)
def test_errors_name_file_line_and_key(tmp_path, text, line, key, words):
    path = tmp_path / "bad.toml"
    with pytest.raises(ConfigError) as info:
        parse_study_config(text, path=path)
    err = info.value
    assert (err.path, err.line, err.column) == (str(path), line, key)
    assert words in str(err)
    assert str(err).startswith(f"{path}: line {line}")


def test_dataclass_checks_without_a_file():
    """The same checks guard a configuration built in code (e.g. shrunk with replace)."""
    config = load_study_config(TINY)
    with pytest.raises(ConfigError, match="replicates must be an integer >= 1"):
        replace(config, replicates=0)
    with pytest.raises(ConfigError, match="unknown IMU grade"):
        replace(config, imu_grades=("consumer",))
    assert isinstance(replace(config, replicates=1), StudyConfig)


def test_cli_bad_config_is_one_line_and_exit_2(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text("[study]\nname = 'x'\n\n[grid]\nimu_grade = 'gold'\n")
    status = main(["-q", "study", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert status == 2
    assert err == (f"error: {path}: line 5, grid.imu_grade: unknown IMU grade 'gold'; presets "
                   "are perfect, paper2017, navigation, tactical, mems\n")
    assert not (tmp_path / "out").exists()


def test_issue18_non_utf8_study_file_is_a_located_error(tmp_path, capsys):
    """A byte that is not UTF-8 raised UnicodeDecodeError; now the file and the line."""
    path = tmp_path / "s.toml"
    path.write_bytes(b'[study]\nname = "\xff"\n')
    with pytest.raises(ConfigError) as info:
        load_study_config(path)
    assert (info.value.path, info.value.line) == (str(path), 2)
    out = tmp_path / "out"
    assert main(["study", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"error: {path}: line 2: not UTF-8 text (byte 0xff)"
    assert not out.exists()


@pytest.mark.parametrize("text,line,words", [
    ("[study]\nx = " + "[" * 100_000 + "]" * 100_000 + "\n", None, "nested too deeply"),
    ("[study]\nseed = " + "9" * 5000 + "\n", None, "4300 digits"),
    ("[study]\nreplicates = 20000000000\n", 2, "20000000000 runs, more than 1000000"),
])
def test_issue18_toml_at_its_limits_is_a_located_error(text, line, words):
    """Found by the fuzz suite: RecursionError and ValueError escaped tomllib, and a typo in
    ``replicates`` listed 2e10 runs."""
    with pytest.raises(ConfigError, match=words) as info:
        parse_study_config(text, path="s.toml")
    assert info.value.line == line and "\n" not in str(info.value)


def test_a_track_csv_given_as_a_study_says_it_is_not_a_study_file(tmp_path, capsys):
    """Audit finding: 'railnav study TRACK.csv' said only 'line 3: Expected ...' (the
    TOML parser's words). Now the file, the line (the track's first line that is not a
    comment: its CSV header) and 'not a TOML study file'; a .toml with a typo is 'not
    valid TOML'."""
    track = DATA / "tracks" / "curvy.csv"
    header = next(n for n, line in enumerate(track.read_text().splitlines(), start=1)
                  if line.strip() and not line.startswith("#"))
    out = tmp_path / "out"
    assert main(["study", str(track), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {track}: line {header}: not a TOML study file (")
    assert "\n" not in err and not out.exists()
    with pytest.raises(ConfigError, match=r": line 2: not valid TOML \(Expected newline"):
        parse_study_config("[study]\nseed = 1 2\n", path=tmp_path / "s.toml")
