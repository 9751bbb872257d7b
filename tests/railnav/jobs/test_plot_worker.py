"""The helper process that draws a run's figures (`railnav.jobs.plot_worker`).

References: the figures drawn in the command's own process (the path without fork) must be
the same bytes; a drawing process that is killed, or whose figure fails, must leave no
output directory (issue 18's contract) and say so in one line, or raise its exception.
"""
from __future__ import annotations

import errno
import importlib
import os
import signal
import time
from pathlib import Path

import pytest

import railnav.jobs.plot_worker as plot_worker
from railnav.cli import main
from railnav.simulation.scenarios import TRACKS_DIR

PAPER = str(TRACKS_DIR / "paper2017.csv")
RUN = ["-q", "run", PAPER, "--duration-s", "20"]
FIGURES = ("errors.png", "track.png")

pytestmark = pytest.mark.skipif(not plot_worker.can_fork(), reason="helpers fork (Linux)")


def _nothing_written(parent: Path, out: Path) -> bool:
    return not out.exists() and not [p for p in parent.iterdir() if p.name.startswith(".")]


def test_helpers_draw_the_same_figures_as_the_command_itself(tmp_path, monkeypatch):
    """Reference: the same run with its figures drawn in the command's process."""
    assert main([*RUN, "--out", str(tmp_path / "helpers")]) == 0
    monkeypatch.setattr(plot_worker, "can_fork", lambda: False)
    assert main([*RUN, "--out", str(tmp_path / "here")]) == 0
    for name in FIGURES:
        assert (tmp_path / "helpers" / name).read_bytes() == \
            (tmp_path / "here" / name).read_bytes(), name


def test_a_killed_helper_is_one_line_and_leaves_nothing(tmp_path, monkeypatch, capsys):
    submit = plot_worker.PlotHelper.submit

    def kill_then_submit(self, figures):
        os.kill(self.pid, signal.SIGKILL)
        os.waitpid(self.pid, os.WNOHANG)
        submit(self, figures)
    monkeypatch.setattr(plot_worker.PlotHelper, "submit", kill_then_submit)
    out = tmp_path / "run"
    assert main([*RUN, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["error: the process drawing the figures ended without finishing them "
                   "(killed by SIGKILL): nothing was written"]
    assert _nothing_written(tmp_path, out)


@pytest.mark.parametrize("module, function, png", [
    ("railnav.evaluation.plots", "errors_figure", "errors.png"),            # the helper
    ("railnav.evaluation.map_plots", "track_estimate_figure", "track.png")])  # its fork
def test_a_drawing_process_that_dies_is_one_line(tmp_path, monkeypatch, capsys, module,
                                                 function, png):
    """A figure whose drawing kills its process (as the system would, out of memory):
    the helper itself (first figure) or the fork of it drawing the second."""
    monkeypatch.setattr(importlib.import_module(module), function,
                        lambda *a, **k: os.kill(os.getpid(), signal.SIGKILL))
    out = tmp_path / "run"
    assert main([*RUN, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: the process drawing ")
    assert "(killed by SIGKILL): nothing was written" in err[0]
    assert (png == "track.png") == (png in err[0])      # the fork names its figure
    assert _nothing_written(tmp_path, out)


def test_a_figure_that_cannot_be_written_is_located(tmp_path, monkeypatch, capsys):
    import railnav.evaluation.plots as plots

    def disk_full(fig, path, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), os.fspath(path))
    monkeypatch.setattr(plots, "save_png", disk_full)      # the helpers fork with it
    out = tmp_path / "run"
    assert main([*RUN, "--out", str(out)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"error: {out / 'errors.png'}: cannot write: {os.strerror(errno.ENOSPC)} "
        "(nothing was written)")
    assert _nothing_written(tmp_path, out)


def test_a_bug_in_a_figure_is_raised_with_the_helpers_traceback(tmp_path, monkeypatch):
    import railnav.evaluation.map_plots as map_plots

    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug in the map")
    monkeypatch.setattr(map_plots, "track_estimate_figure", broken)
    out = tmp_path / "run"
    with pytest.raises(ZeroDivisionError, match="a bug in the map") as caught:
        main([*RUN, "--out", str(out)])
    assert "in broken" in str(caught.value.__cause__)       # the helper's own traceback
    assert _nothing_written(tmp_path, out)


def test_leaving_ends_a_helper_still_drawing():
    """A helper and its fork busy for a minute end when the command leaves (an error,
    Ctrl-C), and are waited for."""
    sleep = plot_worker.Figure("time.sleep", (60.0,))
    started = time.perf_counter()
    with plot_worker.PlotHelper() as helper:
        helper.submit([sleep, sleep])
        pid = helper.pid
        while len(_states_of_group(pid)) < 2:    # the helper and its fork, both sleeping
            assert time.perf_counter() - started < 30.0
            time.sleep(0.05)
    assert time.perf_counter() - started < 30.0
    with pytest.raises(ChildProcessError):       # ended and reaped
        os.waitpid(pid, os.WNOHANG)
    # its fork too: the helper waits until every process of the group has closed its files
    # (`_wait_closed`), which the kernel does early in a killed process's exit; the rest
    # of the exit (state R, then Z) may still be running when `close` returns (seen once
    # in a fresh-clone CI), so allow it a moment to finish
    ended = time.perf_counter()
    while not set(_states_of_group(pid)) <= {"Z"} and time.perf_counter() - ended < 5.0:
        time.sleep(0.01)
    assert set(_states_of_group(pid)) <= {"Z"}   # ended (init reaps it)


def _states_of_group(pgid: int) -> list[str]:
    """The states (``/proc/PID/stat``) of the processes of the group `pgid`."""
    states = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:                          # ended meanwhile
            continue
        if int(fields[2]) == pgid:               # state, ppid, pgrp, ...
            states.append(fields[0])
    return states


def test_without_fork_the_figures_are_drawn_by_wait(tmp_path, monkeypatch):
    monkeypatch.setattr(plot_worker, "can_fork", lambda: False)
    source, target = tmp_path / "a.txt", tmp_path / "b.txt"
    source.write_text("drawn")
    with plot_worker.PlotHelper() as helper:
        assert helper.pid is None
        helper.submit([plot_worker.Figure("shutil.copyfile", (source, target))])
        assert not target.exists()
        helper.wait()
    assert target.read_text() == "drawn"
