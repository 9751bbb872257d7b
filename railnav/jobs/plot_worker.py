"""A run's figures drawn by a helper process while the run writes its tables.

``railnav run`` starts a `PlotHelper` before it simulates and filters: a fork of the command
(it shares the modules already imported) that imports matplotlib and the plotting modules at
once, on the other core, draws a small figure in memory (fonts loaded, the PNG encoder
started: `railnav.evaluation.plot_style.warm_up`), lays out the figures it expects, their
axes and ticks (`PlotHelper`'s ``ahead``: `railnav.evaluation.plots.lay_out_run`), and
then waits. When the run has its
result it sends the figures to draw (`Figure`: a function's name, its arguments — the run's
tables, pickled once — and the PNG it writes), writes its CSV files and ``summary.json``
meanwhile, and waits until every figure is written. The helper draws the first figure itself
and each other one in a fork of itself made then (matplotlib imported and the tables
received once, shared by the forks), so the figures are drawn side by side: the user waits
for the longest one, not for matplotlib's import and every figure one after the other. The
CPU time is not smaller: the tables are pickled, and the helper imports what the command
would.

The figures are written into the run's output directory, as in-process drawing would, so
the directory is still written whole or not at all (`trackmodel.files.output_directory`):
the command waits for every figure before the directory is renamed into place, and any
failure of the helper is raised in the command, which then removes the directory:

* an exception while drawing (a bug, a file that cannot be written) is raised again in the
  command, the same exception with the helper's traceback as its cause (an `OSError` thus
  reads ``cannot write: ... (nothing was written)``, as in-process);
* a drawing process that ends without an answer (killed, out of memory) raises
  `railnav.errors.PlottingError`, one line;
* when the command leaves early (an error, ``Ctrl-C``) or ends in any way, the helper and
  its forks end too: they are a process group of their own, which the command kills and
  waits for before the output directory is removed; each is also killed by the system
  when its parent process ends (``PR_SET_PDEATHSIG``), SIGKILL of the command included.

Where processes cannot be forked (`can_fork`: not Linux) the figures are drawn in the
command's process, one after the other (`draw`).
"""
from __future__ import annotations

import ctypes
import gc
import importlib
import logging
import multiprocessing
import os
import pickle
import select
import signal
import sys
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from railnav.errors import PlottingError

__all__ = ["Figure", "PlotHelper", "draw", "can_fork"]

log = logging.getLogger(__name__)

#: What the helper imports while it waits: matplotlib through the plotting modules, and
#: what the figures import when first drawn (the map projects onto the track:
#: `trackmodel.project`, SciPy's spatial package, ~0.05 s of each run's ``track.png``).
_WARM_MODULES = ("railnav.evaluation.plots", "railnav.evaluation.map_plots",
                 "trackmodel.project")
#: Longest wait for the helper's processes to end once killed, s.
_END_TIMEOUT_S = 10.0


@dataclass(frozen=True)
class Figure:
    """One figure to draw: ``module.function(*args, **kwargs)`` writes `path`.

    The function is named rather than given, so that the command does not import
    matplotlib to refer to it.
    """

    function: str
    args: tuple = ()
    kwargs: dict = field(default_factory=dict)
    path: Path | None = None

    def draw(self) -> None:
        """Draw it in this process."""
        module, name = self.function.rsplit(".", 1)
        getattr(importlib.import_module(module), name)(*self.args, **self.kwargs)


def draw(figures) -> None:
    """Draw `figures` in this process, one after the other."""
    for figure in figures:
        figure.draw()


def can_fork() -> bool:
    """Whether the helper can be forked: Linux (macOS has ``fork``, but its system
    libraries are not safe across it; Windows has none)."""
    return sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()


class _RemoteTraceback(Exception):
    """The helper's traceback, as the cause of the exception raised again here."""

    def __init__(self, text: str) -> None:
        super().__init__(text)
        self.text = text

    def __str__(self) -> str:
        return f'\n"""\n{self.text}"""'


class PlotHelper:
    """The helper process that draws a run's figures (module docstring).

    Use as a context manager around the run: entering forks the helper (none where
    `can_fork` is False), `submit` hands it the figures, `wait` returns when every figure is
    written, and leaving ends the helper and its forks in any case.
    """

    def __init__(self, ahead: Figure | None = None) -> None:
        self.ahead = ahead       # a call the helper makes once it has imported (see _serve)
        self.pid: int | None = None
        self._conn = None
        self._alive = None       # read end of a pipe every helper process holds open
        self._pending = False
        self._local: list[Figure] = []

    def __enter__(self) -> PlotHelper:
        if can_fork():
            self._start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _start(self) -> None:
        here, there = multiprocessing.Pipe()
        alive_r, alive_w = os.pipe()
        parent = os.getpid()
        for stream in (sys.stdout, sys.stderr):
            stream.flush()                   # or the helper would print it again
        pid = os.fork()
        if pid == 0:                         # the helper: never returns
            code = 1
            try:
                here.close()
                os.close(alive_r)
                _serve(there, parent, self.ahead)
                code = 0
            finally:
                os._exit(code)
        try:
            os.setpgid(pid, pid)   # as the helper does: its group exists before any kill
        except OSError:            # it did so already (EACCES), or has ended (ESRCH)
            pass
        there.close()
        os.close(alive_w)
        self.pid, self._conn, self._alive = pid, here, alive_r

    def submit(self, figures) -> None:
        """Hand `figures` to the helper (returns at once; without a helper, they are drawn
        by `wait`)."""
        figures = list(figures)
        if self._conn is None:
            self._local += figures
            return
        if figures:
            try:
                self._conn.send(figures)
            except (BrokenPipeError, ConnectionError):
                pass                             # it ended: `wait` says how
            self._pending = True

    def wait(self) -> None:
        """Return when every figure submitted is written.

        Raises
        ------
        railnav.errors.PlottingError
            A drawing process ended without answering (killed, out of memory).
        Exception
            The exception a figure raised, with the helper's traceback as its cause.
        """
        draw(self._local)
        self._local = []
        if not self._pending:
            return
        try:
            answer = self._conn.recv()
        except (EOFError, ConnectionError):
            raise PlottingError(f"the process drawing the figures ended without finishing "
                                f"them ({self._end()}): nothing was written") from None
        self._pending = False
        if answer is not None:
            exc, text = answer
            raise exc from _RemoteTraceback(text)

    def close(self) -> None:
        """End the helper and its forks and wait for them: an idle helper loses nothing,
        and one still drawing is killed (the command is leaving without its figures)."""
        if self.pid is None:
            return
        self._end()
        self._conn.close()
        os.close(self._alive)
        self.pid = self._conn = self._alive = None
        self._pending = False

    def _end(self) -> str:
        """Kill the helper's process group and wait for all of it; how the helper ended,
        in words."""
        try:
            os.killpg(self.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        _wait_closed(self._alive)
        try:
            _, status = os.waitpid(self.pid, 0)
        except ChildProcessError:             # reaped already
            return "ended"
        return _how_it_ended(status)


def _wait_closed(fd: int) -> None:
    """Return when the write ends of the pipe `fd` reads are all closed (its holders
    ended), or after `_END_TIMEOUT_S`."""
    while select.select([fd], [], [], _END_TIMEOUT_S)[0]:
        if not os.read(fd, 4096):
            return


def _how_it_ended(status: int) -> str:
    code = os.waitstatus_to_exitcode(status)
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


#: ``prctl`` option: the signal this process gets when its parent ends (Linux).
_PR_SET_PDEATHSIG = 1


def _die_with(parent_pid: int) -> None:
    """Be killed when the parent process ends, however it ends (SIGKILL included): a
    helper must not go on writing into an output directory that is being removed."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):    # no prctl: the command's end still stops it
        pass
    if os.getppid() != parent_pid:          # the parent ended before the prctl
        os._exit(0)


def _serve(conn, parent_pid: int, ahead: Figure | None = None) -> None:
    """The helper: import the plotting modules (and call `ahead`, which prepares what
    it can of the figures: `railnav.evaluation.plots.lay_out_run`), then draw each list of
    figures received and answer None or (exception, traceback text); return at the end of
    the pipe."""
    os.setpgid(0, 0)          # a group of its own (with its forks): the command ends it
    _die_with(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)     # Ctrl-C is the command's to handle
    gc.freeze()                 # the inherited objects: never scanned, their pages not copied
    gc.disable()                # nor matplotlib's, imported now; and no collection while
    try:                        # drawing (`_draw_all`)
        for name in _WARM_MODULES:
            importlib.import_module(name)
        importlib.import_module("railnav.evaluation.plot_style").warm_up()   # fonts, PNG
        if ahead is not None:
            ahead.draw()
    except Exception:          # noqa: BLE001  (drawing raises it again, with its traceback)
        pass
    gc.freeze()
    while True:
        try:
            message = conn.recv_bytes()
        except (EOFError, ConnectionError, OSError):
            return
        try:
            conn.send(_draw_all(message))
        except (BrokenPipeError, ConnectionError, OSError):
            return
        gc.collect()            # what the helper's own figure left, once it has answered


def _draw_all(message: bytes):
    """Draw the pickled list of figures `message`: the first here, each other in a fork
    of this process; the first failure, or None.

    The cyclic garbage collector is off in the helper and its forks (`_serve`): a fork
    draws one figure and ends, and its collections, which touch (copy) the pages of every
    object they scan, were ~0.01-0.02 s CPU of a run's figure; what a figure leaves is
    freed when its process ends, or by the helper once it has answered (the peak memory
    of a 1000-s trip's figure is the same, 183 MB)."""
    try:
        figures = pickle.loads(message)
    except BaseException as exc:        # noqa: BLE001  (every failure goes to the command)
        return _failure(exc, None)
    forks = [_fork_drawing(figure) for figure in figures[1:]]
    answers = [_draw_one(figures[0])] if figures else []
    answers += [_collect(*fork) for fork in forks]
    return next((a for a in answers if a is not None), None)


def _draw_one(figure: Figure):
    try:
        figure.draw()
        return None
    except BaseException as exc:        # noqa: BLE001  (every failure goes to the command)
        return _failure(exc, figure)


def _fork_drawing(figure: Figure) -> tuple[int, int, Figure]:
    """A fork that draws `figure` and writes its pickled answer into a pipe: (its pid,
    the pipe's read end, the figure)."""
    read, write = os.pipe()
    helper = os.getpid()
    pid = os.fork()
    if pid == 0:
        try:
            os.close(read)
            _die_with(helper)
            data = pickle.dumps(_draw_one(figure))
            while data:
                data = data[os.write(write, data):]
        finally:
            os._exit(0)
    os.close(write)
    return pid, read, figure


def _collect(pid: int, read: int, figure: Figure):
    """The answer of the fork `pid` drawing `figure` (a `PlottingError` if it ended
    without one)."""
    chunks = []
    while chunk := os.read(read, 1 << 16):
        chunks.append(chunk)
    os.close(read)
    _, status = os.waitpid(pid, 0)
    if chunks:
        return pickle.loads(b"".join(chunks))
    return (PlottingError(f"the process drawing {figure.path} ended without finishing it "
                          f"({_how_it_ended(status)}): nothing was written"), "")


def _failure(exc: BaseException, figure: Figure | None) -> tuple[BaseException, str]:
    """(the exception, or a `PlottingError` saying what it was where it cannot be pickled
    back, and the traceback text)."""
    text = traceback.format_exc()
    try:
        pickle.loads(pickle.dumps(exc))
    except Exception:                  # noqa: BLE001  (any pickling failure)
        what = "a figure" if figure is None else figure.path
        exc = PlottingError(f"drawing {what}: {type(exc).__name__}: {exc}")
    return exc, text
