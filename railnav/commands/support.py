"""Helpers shared by the command handlers: progress bars and small argument types."""
from __future__ import annotations

import argparse
import contextlib
import gc
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

from gnss_obs.sim_events import Outage
from railnav.errors import ConfigError

__all__ = ["progress_bar", "positive_float", "nonnegative_float", "positive_int",
           "nonnegative_int", "outage_window", "lat_lon_h", "add_augmentation_arguments",
           "augmentation_requested", "output_path", "same_file",
           "check_outputs", "add_output_arguments", "output_dir", "written_line",
           "imports_without_gc", "one_of_pair"]


@contextlib.contextmanager
def imports_without_gc() -> Iterator[None]:
    """Import a command's modules with the cyclic garbage collector paused; the first time
    in a process, freeze what is alive then.

    Importing NumPy, SciPy, pandas and our ~150 modules makes objects that live as long as
    the process, and the collector scans them again and again meanwhile (~220 collections,
    ~0.1 s CPU of the ~0.8 s import of ``railnav run``). Frozen (`gc.freeze`), later
    collections skip them. Only the first time: a process that calls the commands again
    and again (a test session) freezes its objects once. Numbers are not affected; the
    collector is on again at the end, as it was before.
    """
    was_on = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_on:
            if not gc.get_freeze_count():
                gc.freeze()
            gc.enable()


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


def one_of_pair(on: tuple[str, bool], off: tuple[str, bool], *, default: str) -> str | None:
    """The flag given of an on/off pair (``("--x", given)``, ``("--no-x", given)``), or
    None.

    Raises
    ------
    ConfigError
        Both given: ``"--x, --no-x: give one (<default>)"``.
    """
    given = [flag for flag, value in (on, off) if value]
    if len(given) == 2:
        raise ConfigError(f"{on[0]}, {off[0]}: give one ({default})")
    return given[0] if given else None


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


def lat_lon_h(text: str) -> tuple[float, float, float]:
    """argparse type for ``LAT,LON,H``: latitude and longitude in degrees, height in m."""
    try:
        lat_deg, lon_deg, h_m = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not LAT,LON,H (degrees, degrees, metres)") from None
    if not (-90.0 <= lat_deg <= 90.0 and -180.0 <= lon_deg <= 360.0
            and abs(h_m) < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: need -90 <= LAT <= 90, "
                                         "-180 <= LON <= 360 and a finite H")
    return lat_deg, lon_deg, h_m


def add_augmentation_arguments(p) -> None:
    """``--base``, ``--base-position``, ``--max-age-s``, ``--smooth-window-s``, ``--sp3``
    (shared by ``spp`` and ``run``)."""
    p.add_argument("--base", metavar="BASE.rnx",
                   help="base-station RINEX observations: code-differential (DGNSS) "
                        "corrections per satellite and epoch")
    p.add_argument("--base-position", type=lat_lon_h, metavar="LAT,LON,H",
                   help="base antenna latitude, longitude (degrees) and ellipsoidal height "
                        "(m); default: the base header's APPROX POSITION XYZ")
    p.add_argument("--max-age-s", type=nonnegative_float, default=None,
                   help="oldest base correction applied, s (default: gnss_obs.DgpsConfig's, "
                        "30 s as RTKLIB's maxage)")
    p.add_argument("--smooth-window-s", type=positive_float, metavar="S",
                   help="carrier-smooth the code (Hatch filter, cycle slips from LLI, "
                        "geometry-free, Melbourne-Wuebbena, Doppler) over up to S seconds")
    p.add_argument("--sp3", nargs="+", default=[], metavar="SP3",
                   help="precise orbit/clock files instead of the broadcast ephemeris")


def augmentation_requested(args: argparse.Namespace) -> bool:
    """True when any of ``--base``, ``--base-position``, ``--smooth-window-s``, ``--sp3``."""
    return bool(args.base or args.base_position is not None or args.smooth_window_s
                or args.sp3)


def output_path(text: str) -> str:
    """argparse type of an output file or folder: not empty (``--out ''`` would write into
    the working directory under a hidden temporary name)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an output path cannot be empty")
    return text


def add_output_arguments(p, default: str) -> None:
    """``--out DIR`` (default `default`: every command's is ``railnav-<command>``, never
    the working directory) and ``--overwrite``: the output directory is written whole or
    not at all (`trackmodel.files.output_directory`)."""
    p.add_argument("--out", default=default, type=output_path, metavar="DIR",
                   help=f"output directory (default: {default}); an existing one that is "
                        "not empty is refused unless --overwrite")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing --out whole (none of its old files is kept)")


def output_dir(args: argparse.Namespace, inputs=()):
    """The ``--out`` of `add_output_arguments` as an `output_directory` context: checked
    before any work, written into a hidden sibling, renamed into place when complete."""
    from trackmodel.files import output_directory
    return output_directory(args.out, overwrite=args.overwrite,
                            inputs=[p for p in inputs if p is not None])


def written_line(out: str | os.PathLike, written, root: str | os.PathLike) -> str:
    """``DIR/: a.csv, b.png``: what a command wrote, `written` being paths under `root`
    (the temporary directory that became `out`)."""
    names = [str(Path(p).relative_to(root)) for p in written]
    return f"{out}{os.sep}: {', '.join(names)}"


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
