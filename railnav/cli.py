"""The ``railnav`` command line: argument parsing, logging, one-line errors.

Thin by design (STYLE.md §2.11): each subcommand lives in `railnav.commands` and calls
the public API. Any error a user can cause (a bad file, a bad option value) ends with one
line ``error: FILE: problem`` on stderr and exit status 2, no traceback (``--debug``
shows it). A filter that diverges, or a process drawing the figures that is killed, exits
with status 1, also in one line.
"""
from __future__ import annotations

import argparse
import atexit
import importlib
import logging
import os
import pkgutil
import re
import sys
import threading
from collections.abc import Sequence

from railnav.blas_threads import one_blas_thread

one_blas_thread()      # before the imports below load NumPy (its OpenBLAS reads it then)

import railnav.commands  # noqa: E402
from ekf.errors import FilterDivergedError, FilterError  # noqa: E402
from gnss_obs.errors import GnssError  # noqa: E402
from railnav.deferred_imports import defer_numpy_tools  # noqa: E402
from railnav.errors import PlottingError, RailnavError  # noqa: E402
from strapdown.errors import StrapdownError  # noqa: E402
from trackmodel.errors import InputError, TrackError  # noqa: E402

__all__ = ["main", "console_main", "build_parser", "flag_names"]

#: Errors a user's input can cause: one line, exit 2.
USER_ERRORS = (InputError, TrackError, StrapdownError, GnssError, RailnavError, FilterError,
               OSError)

#: What ``-q`` does, for every command: the report on stdout is the command's result (what
#: it wrote, the figures it found) and stays; ``2>/dev/null`` or ``>/dev/null`` silence more.
QUIET_HELP = ("no progress bars, and log messages on stderr only for warnings and errors "
              "(even with -v); the report on stdout is still printed")

EXIT_USAGE = 2
EXIT_FAILURE = 1
#: Ctrl-C (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130


class _VersionAction(argparse.Action):
    """``--version``: the installed distribution's version, looked up only when asked."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help="print the version and exit"):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from railnav import __version__
        print(f"railnav {__version__}")          # stdout, as argparse's own version action
        parser.exit()


class _Parser(argparse.ArgumentParser):
    """argparse's parser whose usage errors (a bad option value, a missing argument) are
    one line, as the command line's other input errors: ``error: MESSAGE (PROG --help)``
    and exit 2, instead of the whole usage block before the message. Subcommand parsers
    are of this class too (``add_subparsers`` takes the parent's)."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"error: {message} ({self.prog} --help)\n")


def _add_global_flags(parser: argparse.ArgumentParser, *, top: bool) -> None:
    """``-v``, ``-q`` and ``--debug``: on the top parser with their defaults, on every
    subcommand (recursively) with no default, so that a flag given after the subcommand
    counts and one given before is not reset."""
    extra = {} if top else {"default": argparse.SUPPRESS}
    parser.add_argument("-v", "--verbose", action="count", help="more log output (-vv for "
                        "debug)", **({"default": 0} if top else extra))
    parser.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP, **extra)
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an error", **extra)


def _subparsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """Every subcommand parser below `parser` (``track fit``, ``network run``...)."""
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in dict.fromkeys(action.choices.values()):
                found += [child, *_subparsers(child)]
    return found


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The argument parser: for command-line arguments `argv` that name a command, that
    command's only (its module alone is imported: ~0.05 s less at every start); otherwise,
    and without `argv`, every command's (``railnav --help`` lists them)."""
    parser = _Parser(
        prog="railnav",
        description="Track-constrained navigation of rail vehicles.")
    parser.add_argument("--version", action=_VersionAction)
    _add_global_flags(parser, top=True)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in _command_named(argv) or command_modules():
        importlib.import_module(f"railnav.commands.{name}").register(sub)
    for child in _subparsers(parser):
        _add_global_flags(child, top=False)
    return parser


def _command_named(argv: Sequence[str] | None) -> list[str]:
    """``[name]`` when the first argument that is not a flag (the global flags take no
    value) is a command module's name, else ``[]``."""
    token = next((a for a in argv or () if not a.startswith("-")), None)
    if token is None or token not in {info.name for info in
                                      pkgutil.iter_modules(railnav.commands.__path__)}:
        return []
    module = importlib.import_module(f"railnav.commands.{token}")
    return [token] if callable(getattr(module, "register", None)) else []


def command_modules() -> list[str]:
    """Names of the subcommand modules in `railnav.commands` (those defining ``register``)."""
    names = []
    for info in pkgutil.iter_modules(railnav.commands.__path__):
        module = importlib.import_module(f"railnav.commands.{info.name}")
        if callable(getattr(module, "register", None)):
            names.append(info.name)
    return sorted(names)


def _configure_logging(verbose: int, quiet: bool) -> None:
    level = logging.WARNING if quiet or verbose == 0 else (
        logging.INFO if verbose == 1 else logging.DEBUG)
    logging.basicConfig(level=level, format="%(levelname)s: %(name)s: %(message)s",
                        stream=sys.stderr, force=True)


def _one_line(exc: BaseException, parser: argparse.ArgumentParser) -> str:
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or exc}"
    text = " ".join(str(exc).split()) or type(exc).__name__
    flags = flag_names(parser)
    for name in getattr(exc, "arguments", ()):
        flag = flags.get(name, flags.get(name.removesuffix("_path")))
        if flag is not None:
            text = re.sub(rf"\b{name}\b", flag, text)
    return text


def flag_names(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Each destination of `parser`'s options and its subcommands' and its flag
    (``start_gps_time_s`` -> ``--start-gps-time-s``): how a library error that names its
    arguments (`railnav.errors.RailnavError.arguments`) reads on the command line; a
    library argument ``X_path`` is the flag of ``X`` (``imu_path`` -> ``--imu``)."""
    names = {}
    for p in [parser, *_subparsers(parser)]:
        for action in p._actions:
            longs = [o for o in action.option_strings if o.startswith("--")]
            if longs:
                names.setdefault(action.dest, longs[0])
    return names


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 1 failure, 2 bad input)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    defer_numpy_tools()        # before a command imports SciPy (0.05-0.1 s CPU a start)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    _configure_logging(args.verbose, args.quiet)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt as exc:     # a message when the command says what was kept
        print(f"error: {str(exc) or 'interrupted'}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (FilterDivergedError, PlottingError) as exc:
        if args.debug:
            raise
        print(f"error: {_one_line(exc, parser)}", file=sys.stderr)
        return EXIT_FAILURE
    except USER_ERRORS as exc:
        if args.debug:
            raise
        print(f"error: {_one_line(exc, parser)}", file=sys.stderr)
        return EXIT_USAGE


def console_main() -> None:
    """The ``railnav`` command and ``python -m railnav.cli``: `main`, then the process ends
    without the interpreter's teardown.

    The outputs are written and closed by then; what remains is freeing every object and
    module one by one (~0.1 s at the end of each ``railnav run``, more under load). The
    output streams are flushed and the exit handlers run (logging, multiprocessing) first.
    A command that left a non-daemon thread running ends the usual way, which waits for it.
    """
    code = main()
    if any(t.is_alive() and not t.daemon for t in threading.enumerate()
           if t is not threading.main_thread()):
        sys.exit(code)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):      # a closed pipe (``| head``), a closed stream
            pass
    atexit._run_exitfuncs()                # what the interpreter would run before teardown
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    console_main()
