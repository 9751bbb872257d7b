"""What the fuzz suite (``tests/fuzz/``) shares: its budget, a time limit per case, and
strategies that mutate a valid file the way a damaged one looks.

Budget: the hypothesis profile named by the environment variable ``RAILNAV_FUZZ``:

* ``ci`` (the default): `CI_EXAMPLES` examples per reader test — the whole suite in
  about half a minute on one core;
* ``local``: `LOCAL_EXAMPLES` examples per test, for a run before a release
  (``RAILNAV_FUZZ=local pytest tests/fuzz``).

Each case must finish within `CASE_LIMIT_S` of CPU time: an interval timer on the process's
CPU clock (`time_limit`, ``ITIMER_PROF``) turns a case that would hang into a failure that
shows the input, instead of a suite that never ends. CPU, not wall-clock time: a reader's
hang spins, and on a loaded machine (two pytest workers and other work on 2 cores) the wall
clock ran past 10 s on a mutated network whose unmutated load takes ~0.5 s of CPU;
hypothesis' own deadline is wall-clock, so it is off.
"""
from __future__ import annotations

import contextlib
import os
import signal
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

__all__ = ["FUZZ", "CASE_LIMIT_S", "time_limit", "mutated", "csv_cells", "FuzzTimeout",
           "read_fuzzed"]

CI_EXAMPLES = 40
LOCAL_EXAMPLES = 1000
#: The longest a reader may take on any input, s (the slowest plausible track, a 9 500 km
#: curved section, builds in ~3.5 s).
CASE_LIMIT_S = 10.0

_COMMON = dict(deadline=None, database=None, print_blob=True,
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                      HealthCheck.function_scoped_fixture])
settings.register_profile("fuzz-ci", max_examples=CI_EXAMPLES, **_COMMON)
settings.register_profile("fuzz-local", max_examples=LOCAL_EXAMPLES, **_COMMON)
#: The settings of every fuzz test (profile from ``RAILNAV_FUZZ``, default ``ci``).
FUZZ = settings.get_profile(f"fuzz-{os.environ.get('RAILNAV_FUZZ', 'ci')}")


class FuzzTimeout(AssertionError):
    """A reader ran longer than `CASE_LIMIT_S` on one input."""


@contextlib.contextmanager
def time_limit(seconds: float = CASE_LIMIT_S) -> Iterator[None]:
    """Raise `FuzzTimeout` in the block when it takes more than `seconds` of the process's
    CPU time (SIGPROF; on a platform without it, the block is not bounded)."""
    if not hasattr(signal, "setitimer"):
        yield
        return

    def expired(signum, frame):
        raise FuzzTimeout(f"a reader took more than {seconds} s of CPU on one input")

    previous = signal.signal(signal.SIGPROF, expired)
    signal.setitimer(signal.ITIMER_PROF, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        signal.signal(signal.SIGPROF, previous)


#: Bytes a damaged or hand-edited CSV/TOML file tends to contain.
_NOISE = st.sampled_from([b",", b"\n", b"\r\n", b"#", b"\"", b"'", b" ", b"-", b".", b"e",
                          b"nan", b"inf", b"-inf", b"1e308", b"1e-320", b"0", b"9", b"=",
                          b"[", b"]", b"\xff", b"\xc3", b"\x00", b"\xef\xbb\xbf", b"\t",
                          "é".encode(), b"true", b"\"x\"", b",,,,", b"1e6", b"-0"])


@st.composite
def mutated(draw, original: bytes, *, max_edits: int = 6) -> bytes:
    """`original` after up to `max_edits` edits: a byte replaced, a span deleted, noise
    inserted, a line duplicated or dropped, a digit changed, or the file cut short."""
    data = bytearray(original)
    for _ in range(draw(st.integers(1, max_edits))):
        kind = draw(st.sampled_from(["replace", "delete", "insert", "line", "digit", "cut"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if kind == "replace" and data:
            data[at] = draw(st.integers(0, 255))
        elif kind == "delete":
            del data[at:at + draw(st.integers(1, 12))]
        elif kind == "insert":
            data[at:at] = draw(_NOISE)
        elif kind == "digit":
            digits = [i for i, b in enumerate(data) if 48 <= b <= 57]
            if digits:
                data[draw(st.sampled_from(digits))] = draw(st.integers(48, 57))
        elif kind == "line":
            lines = bytes(data).split(b"\n")
            j = draw(st.integers(0, len(lines) - 1))
            lines[j:j + 1] = [] if draw(st.booleans()) else [lines[j], lines[j]]
            data = bytearray(b"\n".join(lines))
        elif kind == "cut":
            del data[at:]
    return bytes(data)


def csv_cells() -> st.SearchStrategy[str]:
    """A CSV cell as a user (or a broken exporter) might write it."""
    numbers = st.floats(allow_nan=True, allow_infinity=True).map(repr)
    return st.one_of(numbers, st.integers(-10**40, 10**40).map(str),
                     st.sampled_from(["", " ", "nan", "NaN", "inf", "-", "1e", "abc",
                                      "0x10", "1,5", "\"1\"", "1e999", "True"]),
                     st.text(max_size=6))


def read_fuzzed(data: bytes, reader: Callable, errors: tuple[type, ...], *,
                name: str = "input.csv"):
    """`reader` of `data` written to a file `name`: its result, or None after one of
    `errors` (one line, starting with the file's path); anything else fails the test."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        path.write_bytes(data)
        with time_limit():
            try:
                return reader(path)
            except errors as exc:
                text = str(exc)
                assert "\n" not in text and text.startswith(str(path)), text
                return None
