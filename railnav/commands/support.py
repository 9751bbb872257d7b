"""Helpers shared by the command handlers: progress bars and small argument types."""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Callable, Iterator

from gnss_obs.sim_events import Outage
from railnav.errors import ConfigError

__all__ = ["progress_bar", "positive_float", "nonnegative_float", "positive_int",
           "nonnegative_int", "outage_window", "output_path", "same_file", "check_outputs"]

@contextlib.contextmanager
def progress_bar(desc: str, *, enabled: bool = True) -> Iterator[Callable[[int, int], None]]:
    """A ``progress(done, total)`` callback drawing a tqdm bar on stderr.

    The library's long loops accept such a callback (STYLE.md §2.9); only the command
    line turns it into a bar. ``enabled=False`` (``railnav -q``) gives a silent callback.
    """
    if not enabled:
        yield lambda done, total: None
        return
    from tqdm import tqdm

    bar = None

    def update(done: int, total: int) -> None:
        nonlocal bar
        if bar is None:
            # disable=None: no bar when stderr is not a terminal (logs, CI, pipes)
            bar = tqdm(total=total, desc=desc, file=sys.stderr, leave=False,
                       dynamic_ncols=True, mininterval=0.2, disable=None)
        if total and bar.total != total:
            bar.total = total
        bar.update(done - bar.n)   # update() honours mininterval; refresh() would not

    try:
        yield update
    finally:
        if bar is not None:
            bar.close()


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number > 0")
    return value


def nonnegative_float(text: str) -> float:
    """argparse type: a finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (0 <= value < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number >= 0")
    return value


def _integer(text: str, minimum: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < minimum:
        raise argparse.ArgumentTypeError(f"{text!r} must be an integer >= {minimum}")
    return value


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1 (e.g. a number of runs)."""
    return _integer(text, 1)


def nonnegative_int(text: str) -> int:
    """argparse type: an integer >= 0 (e.g. a seed)."""
    return _integer(text, 0)


def outage_window(text: str) -> Outage:
    """argparse type for ``START:DURATION`` (seconds from the trip start): a total outage."""
    try:
        start_s, duration_s = (float(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not START:DURATION in seconds (e.g. 100:50)") from None
    if not (start_s >= 0 and duration_s > 0) or not all(
            abs(x) < float("inf") for x in (start_s, duration_s)):
        raise argparse.ArgumentTypeError(f"{text!r}: need START >= 0 and DURATION > 0 seconds")
    return Outage(start_s, duration_s)


def output_path(text: str) -> str:
    """argparse type of an output file or folder: not empty (``--out ''`` would write into
    the working directory under a hidden temporary name)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an output path cannot be empty")
    return text


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """True when two paths name one file (the same resolved path, or one file through links)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:              # one of them does not exist yet: not the same file
        return False


def check_outputs(inputs: dict[str, str | os.PathLike],
                  outputs: dict[str, str | os.PathLike | None]) -> None:
    """Refuse an output that is an input or another output, before any work.

    Parameters
    ----------
    inputs : dict of description -> path
        E.g. ``{"the survey being fitted": args.polyline}``.
    outputs : dict of option -> path or None
        E.g. ``{"--out": args.out, "--residuals": args.residuals}`` (None: not given).

    Raises
    ------
    ConfigError
        ``FILE: --residuals: is also --out ...``, located at the output and its option.
    """
    taken = dict(inputs)
    for option, path in outputs.items():
        if path is None:
            continue
        for name, other in taken.items():
            if same_file(path, other):
                raise ConfigError(f"is {name}: give a different file (nothing was written)",
                                  path=path, column=option)
        taken[f"also {option}"] = path
