"""Compare two benchmark JSONs field by field, timings apart: did a change move any result?

Usage::

    python benchmarks/compare_results.py OLD.json NEW.json [--list-timings]

Every field of both files is walked (dicts by key, lists by position). A field whose own
name is one of `TIMING_KEYS` (a duration, CPU time or load average of the run: what a
re-run changes by itself) is counted apart and not compared; every other field must be
equal (floats to the bit, NaN equal to NaN; a key missing from one file, or lists of
different lengths, are differences). Prints each difference with its path, and exits 1
when there is one. ``--list-timings`` prints the timing fields that differ too.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path

#: Field names that hold a run's time or the machine's load (the benchmarks' JSONs).
TIMING_KEYS = frozenset({
    "load_average_before", "load_average_after", "wall_s", "navigator_s",
    "navigator_cpu_s", "runtime_s", "best_s", "median_s", "runs_s", "run_s", "cpu_s",
    "end_to_end_s", "end_to_end_cpu_s", "simulation_and_setup_s", "write_s",
    "real_time_factor_end_to_end", "real_time_factor_navigator",
    "real_time_factor_end_to_end_cpu", "real_time_factor_navigator_cpu"})


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return type(a) is type(b) and a == b


def differences(old, new, path: str = "") -> tuple[list[str], list[str]]:
    """The paths where `old` and `new` differ outside `TIMING_KEYS`, and the timing
    fields that differ (``/key/key[index]`` paths)."""
    diffs: list[str] = []
    timings: list[str] = []
    if isinstance(old, dict) and isinstance(new, dict):
        for key in sorted(set(old) | set(new)):
            where = f"{path}/{key}"
            if key not in old or key not in new:
                diffs.append(f"{where}: only in {'new' if key in new else 'old'}")
            elif key in TIMING_KEYS:
                if json.dumps(old[key]) != json.dumps(new[key]):
                    timings.append(where)
            else:
                d, t = differences(old[key], new[key], where)
                diffs += d
                timings += t
    elif isinstance(old, list) and isinstance(new, list):
        if len(old) != len(new):
            diffs.append(f"{path}: {len(old)} items, then {len(new)}")
        else:
            for i, (a, b) in enumerate(zip(old, new)):
                d, t = differences(a, b, f"{path}[{i}]")
                diffs += d
                timings += t
    elif not _same(old, new):
        diffs.append(f"{path}: {old!r} -> {new!r}")
    return diffs, timings


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old", type=Path)
    parser.add_argument("new", type=Path)
    parser.add_argument("--list-timings", action="store_true")
    args = parser.parse_args(argv)
    diffs, timings = differences(*(json.loads(p.read_text()) for p in (args.old, args.new)))
    print(f"{args.old} -> {args.new}: {len(diffs)} differences; {len(timings)} timing "
          f"fields differ ({', '.join(sorted({re.sub(r'.*/', '', t) for t in timings}))})")
    for line in diffs:
        print("  " + line)
    if args.list_timings:
        for line in timings:
            print("  timing " + line)
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
