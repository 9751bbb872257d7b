"""Fuzzed study files (issue 18): `load_study_config` returns a `StudyConfig` or raises
`ConfigError`, located and on one line, within the case time limit (`tests.support.fuzz`).

Two generators: mutations of the shipped ``tiny.toml`` and ``outages.toml`` (damaged bytes,
lost or repeated lines), and documents written from scratch with the file's tables and keys
(and some that are not) holding values of every TOML type.
"""
from __future__ import annotations

import json
import tempfile
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from railnav.errors import ConfigError
from railnav.studies.file import load_study_config
from tests.conftest import DATA
from tests.support.fuzz import FUZZ, mutated, time_limit

ORIGINALS = [(DATA / "studies" / name).read_bytes() for name in ("tiny.toml", "outages.toml")]
KEYS = {"study": ["name", "seed", "replicates", "scenario", "duration_s", "systems", "mode",
                  "chunk_runs", "common_random_numbers", "colour"],
        "grid": ["track", "imu_grade", "speed_mps", "filter", "sigma_pseudorange_m",
                 "sigma_range_rate_mps", "outage_start_s", "outage_duration_s", "outages"],
        "streaming": ["segment_s"], "extra": ["x"]}

_scalars = st.one_of(
    st.integers(-2**70, 2**70), st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(), st.text(max_size=8),
    st.sampled_from(["paper2017", "curvy", "G", "GE", "streaming", "memory", "tactical",
                     "constrained", "gnss-only", "paper2017.csv", "../x.csv", "\x00"]))
_values = st.recursive(_scalars, lambda inner: st.lists(inner, max_size=4), max_leaves=8)


def _toml_value(value) -> str:
    """TOML literal of a generated value (strings as JSON strings are valid TOML basic
    strings; non-finite floats in TOML's spelling)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if value != value:
            return "nan"
        if value in (float("inf"), float("-inf")):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, str):
        return json.dumps(value)
    return str(value)


#: Documents at tomllib's own limits (nesting depth, integer digits).
_EXTREMES = st.sampled_from(["x = " + "[" * 5000 + "]" * 5000, "seed = " + "9" * 5000,
                             "replicates = 10000000000000"])


@st.composite
def study_documents(draw) -> bytes:
    lines = [draw(_EXTREMES)] if draw(st.integers(0, 9)) == 0 else []
    for table in draw(st.lists(st.sampled_from(sorted(KEYS)), max_size=4, unique=True)):
        lines.append(f"[{table}]")
        for key in draw(st.lists(st.sampled_from(KEYS[table]), max_size=6, unique=True)):
            lines.append(f"{key} = {_toml_value(draw(_values))}")
    return ("\n".join(lines) + "\n").encode("utf-8", errors="surrogatepass")


def _load(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "study.toml"
        path.write_bytes(data)
        with time_limit():
            try:
                config = load_study_config(path)
            except ConfigError as exc:
                text = str(exc)
                assert "\n" not in text and text.startswith(str(path)), text
                return
        assert config.replicates >= 1 and len(config.tracks) >= 1


@FUZZ
@given(st.sampled_from(ORIGINALS).flatmap(mutated))
def test_fuzz_mutated_study_files(data):
    _load(data)


@FUZZ
@given(study_documents())
def test_fuzz_generated_study_files(data):
    _load(data)
