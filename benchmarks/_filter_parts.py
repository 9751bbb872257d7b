"""Where the filter's time goes (`bench_speed`'s ``filter_parts``): CPU per component.

`railnav.navigate` on the paper2017 trip (`bench_speed`'s stage trip), with the main
components' methods wrapped by a CPU clock for the run (`time.process_time`: a call
inside another wrapped call counts in the outer one only; none of these nests today):
the compiled step loop, the epoch preparation (satellites at the receiver guess), the
GNSS rows, the filter inputs, the fault screen, the discrete update, the divergence
monitor; ``rest`` is the run's CPU less theirs (loop, history, result, per-epoch glue).
The wrappers cost ~1 µs a call, so the parts add to a little more than ``filter_s``;
the best of `repeats` runs (the one with the smallest total) is reported.
"""
from __future__ import annotations

import functools
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


def filter_parts(run, repeats: int) -> dict:
    """CPU seconds of each of `PARTS` in ``run()`` (one filter run), and ``rest_s``,
    ``total_s``: the best of `repeats` runs."""
    import importlib
    spent: Counter = Counter()
    depth = [0]
    saved = []

    def timed(method, label):
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

    for module, cls_name, name, label in PARTS:
        cls = getattr(importlib.import_module(module), cls_name)
        saved.append((cls, name, cls.__dict__[name]))
        setattr(cls, name, timed(cls.__dict__[name], label))
    best = None
    try:
        for _ in range(repeats):
            spent.clear()
            start = time.process_time()
            run()
            total = time.process_time() - start
            if best is None or total < best["total_s"]:
                best = {**{label: spent[label] for *_, label in PARTS}, "total_s": total}
    finally:
        for cls, name, method in saved:
            setattr(cls, name, method)
    best["rest_s"] = best["total_s"] - sum(best[label] for *_, label in PARTS)
    return best


def paper2017_parts(repeats: int) -> dict:
    """`filter_parts` of the filter alone on `bench_navigator`'s trip (the ``filter``
    figure's run: the paper2017 trip, seed 1, started from the truth)."""
    import bench_navigator
    trip, config, initial = bench_navigator._trip_and_start(seed=1)
    data = trip.sensor_data()
    run = functools.partial(bench_navigator.navigate, trip.track, data, config,
                            initial=initial)
    run()                                     # compiled code loaded, caches warm
    return filter_parts(run, repeats)
