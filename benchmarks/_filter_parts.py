"""Where the filter's time goes (`bench_speed`'s ``filter_parts`` and ``filter_detail``).

`railnav.navigate` on the paper2017 trip (`bench_speed`'s stage trip), with functions
wrapped by a CPU clock for the run (`time.process_time`; the wrappers cost ~1 µs a call,
so the figures add to a little more than ``filter_s``; the best of `repeats` runs, the
one with the smallest total, is reported):

* ``filter_parts`` (`PARTS`): the compiled step loop, the epoch preparation (satellites
  at the receiver guess), the GNSS rows, the filter inputs, the fault screen, the
  discrete update, the divergence monitor; ``rest`` is the run's CPU less theirs (loop,
  history, result, per-epoch glue). A call inside another wrapped call counts in the
  outer one only (none of these nests today).
* ``filter_detail`` (`DETAIL`): what is inside those parts and the rest, each label the
  CPU of its functions' calls, inclusive (labels nest: ``grid_window_s`` is inside
  ``track_grid_s``, which is inside the parts' ``inputs_s``); ``engine_glue_s`` is the
  EKF engine's per-chunk bookkeeping around the compiled loop and the update (input
  checks, history, covariance packing), ``run_setup_s`` and ``run_result_s`` what a run
  does once before and after its loop.
"""
from __future__ import annotations

import functools
import importlib
import time
from collections import Counter

#: (module, class, method, label) of each part.
PARTS = (("ekf.compiled", "CompiledLoop", "run", "c_step_loop_s"),
         ("railnav.filters.gnss_epochs", "GnssEpochs", "prepare_together",
          "epoch_preparation_s"),
         ("railnav.filters.common", "EpochRowBuilder", "rows_of", "gnss_rows_s"),
         ("railnav.filters.constrained", "ConstrainedFilter", "inputs", "inputs_s"),
         ("railnav.filters.fault_detection", "RowScreen", "screen", "fault_screen_s"),
         ("ekf.cd_filter", "CdFilter", "update", "update_s"),
         ("railnav.navigation.monitor", "FilterMonitor", "prior", "monitor_prior_s"),
         ("railnav.navigation.monitor", "FilterMonitor", "epoch", "monitor_epoch_s"))

#: (module, class or None, function, label) of the finer breakdown; a module-level
#: function is wrapped in the module that calls it by that name.
DETAIL = (
    # inputs: the track's parameter grid and the prior's statistical linearization
    ("railnav.filters.track_grid", "TrackParameterGrid", "parameters", "track_grid_s"),
    ("railnav.filters.track_grid", "TrackParameterGrid", "_open", "grid_window_s"),
    ("railnav.filters.constrained", None, "statistical_parameters",
     "statistical_parameters_s"),
    ("railnav.navigation.loop", "ChunkLoop", "_linearization", "jacobian_median_s"),
    # GNSS rows: the receiver's track part at the prior
    ("railnav.filters.common", "GnssRowBuilder", "receiver_part", "receiver_part_s"),
    # fault screen
    ("railnav.filters.screens_together", None, "evaluate_rows", "row_evaluation_s"),
    ("railnav.filters.fault_detection", "RowScreen", "_clock_jump", "clock_jump_test_s"),
    ("railnav.filters.fault_detection", "RowScreen", "_decide", "channel_rows_s"),
    ("railnav.filters.fault_detection", "RowScreen", "_add_influence", "channel_rows_s"),
    ("railnav.filters.screens_together", None, "influence_gains", "influence_gains_s"),
    # monitor: the epoch's own fix, the fix solved where the screen kept rows out, tests
    ("railnav.navigation.monitor", None, "snapshot_fix", "snapshot_fix_s"),
    ("gnss_obs.spp", None, "solve_spp_epoch", "monitor_fix_solve_s"),
    ("railnav.navigation.track_fixes", None, "_spp_on_track", "monitor_fix_solve_s"),
    ("railnav.navigation.track_fixes", "TrackFixes", "near", "monitor_fix_solve_s"),
    ("railnav.navigation.monitor", "FilterMonitor", "_status", "monitor_tests_s"),
    # the engine's bookkeeping around the compiled loop and the update
    ("ekf.cd_filter", "CdFilter", "_shape", "engine_glue_s"),
    ("ekf.cd_filter", None, "_concat", "engine_glue_s"),
    ("ekf.cd_filter", None, "step_data", "engine_glue_s"),
    ("ekf.cd_filter", None, "_check_covariance", "engine_glue_s"),
    ("ekf.cd_filter", None, "pack_sym", "engine_glue_s"),
    ("ekf.cd_filter", None, "unpack_sym", "engine_glue_s"),
    ("ekf.history", "Recorder", "steps", "engine_glue_s"),
    ("ekf.history", "Recorder", "update", "engine_glue_s"),
    ("ekf.history", "Recorder", "result", "engine_glue_s"),
    # once per run
    ("railnav.navigation.navigator", None, "trip_samples", "run_setup_s"),
    ("railnav.navigation.navigator", None, "make_filter", "run_setup_s"),
    ("railnav.navigation.navigator", None, "run_monitor", "run_setup_s"),
    ("railnav.navigation.result", "NavigationResult", "assemble", "run_result_s"),
    ("railnav.navigation.navigator", None, "concatenate_results", "run_result_s"))


def _timed(method, label: str, spent: Counter, depth: list):
    """`method` counting its CPU into ``spent[label]`` unless a call of the same `depth`
    group is already being timed (then it counts in that one)."""
    @functools.wraps(method)
    def wrapper(*args, **kwargs):
        if depth[0]:
            return method(*args, **kwargs)
        depth[0] += 1
        start = time.process_time()
        try:
            return method(*args, **kwargs)
        finally:
            spent[label] += time.process_time() - start
            depth[0] -= 1
    return wrapper


def _install(specs, spent: Counter, *, nested: bool) -> list:
    """Wrap the functions of `specs`; with `nested`, each label has its own guard (labels
    may nest), else one guard for all (a call counts in the outermost). Returns what to
    put back (`_restore`)."""
    shared = [0]
    guards: dict[str, list] = {}
    saved = []
    for module, cls_name, name, label in specs:
        depth = guards.setdefault(label, [0]) if nested else shared
        owner = importlib.import_module(module)
        if cls_name is None:
            original = getattr(owner, name)
            saved.append((owner, name, original))
            setattr(owner, name, _timed(original, label, spent, depth))
            continue
        cls = getattr(owner, cls_name)
        original = cls.__dict__[name]
        saved.append((cls, name, original))
        if isinstance(original, (classmethod, staticmethod)):
            wrapped = type(original)(_timed(original.__func__, label, spent, depth))
        else:
            wrapped = _timed(original, label, spent, depth)
        setattr(cls, name, wrapped)
    return saved


def _restore(saved: list) -> None:
    for owner, name, original in reversed(saved):
        setattr(owner, name, original)


def _best(run, repeats: int, specs, *, nested: bool) -> dict:
    """CPU seconds of each label of `specs` in the best of `repeats` ``run()`` calls, and
    ``total_s``."""
    spent: Counter = Counter()
    labels = list(dict.fromkeys(label for *_, label in specs))
    best = None
    saved = _install(specs, spent, nested=nested)
    try:
        for _ in range(repeats):
            spent.clear()
            start = time.process_time()
            run()
            total = time.process_time() - start
            if best is None or total < best["total_s"]:
                best = {**{label: spent[label] for label in labels}, "total_s": total}
    finally:
        _restore(saved)
    return best


def filter_parts(run, repeats: int) -> dict:
    """CPU seconds of each of `PARTS` in ``run()`` (one filter run), and ``rest_s``,
    ``total_s``: the best of `repeats` runs."""
    best = _best(run, repeats, PARTS, nested=False)
    best["rest_s"] = best["total_s"] - sum(best[label] for *_, label in PARTS)
    return best


def filter_detail(run, repeats: int) -> dict:
    """Inclusive CPU seconds of each label of `DETAIL` in ``run()``, and ``total_s``: the
    best of `repeats` runs."""
    return _best(run, repeats, DETAIL, nested=True)


def _paper2017_run():
    """`bench_navigator`'s filter run (the paper2017 trip, seed 1, started from the
    truth), made once (compiled code loaded, caches warm)."""
    import bench_navigator
    trip, config, initial = bench_navigator._trip_and_start(seed=1)
    data = trip.sensor_data()
    run = functools.partial(bench_navigator.navigate, trip.track, data, config,
                            initial=initial)
    run()
    return run


def paper2017_parts(repeats: int) -> dict:
    """`filter_parts` of the filter alone on `bench_navigator`'s trip (the ``filter``
    figure's run: the paper2017 trip, seed 1, started from the truth)."""
    return filter_parts(_paper2017_run(), repeats)


def paper2017_detail(repeats: int) -> dict:
    """`filter_detail` of the ``filter`` figure's run (as `paper2017_parts`)."""
    return filter_detail(_paper2017_run(), repeats)


if __name__ == "__main__":
    import argparse
    import json
    import os
    import sys
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    parser = argparse.ArgumentParser(description="The filter's CPU by part and in detail "
                                     "(bench_speed's filter_parts and filter_detail alone).")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(json.dumps({"load_average_before": list(os.getloadavg()),
                      "filter_parts": paper2017_parts(args.repeats),
                      "filter_detail": paper2017_detail(args.repeats),
                      "load_average_after": list(os.getloadavg())}, indent=1))
