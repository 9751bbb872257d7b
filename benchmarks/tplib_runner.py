"""tp-lib's train path on one fix log, for the benchmarks (run by a Python >= 3.12 with the
PyPI package ``tp-lib``; a benchmark-only dependency, never railnav's).

Usage::

    PYTHON312 benchmarks/tplib_runner.py FIXES.csv NETWORK.geojson

``FIXES.csv`` has ``latitude, longitude, timestamp`` (RFC 3339 with a zone). Prints one
JSON object: ``runtime_s`` (the path calculation, in this process), ``element`` (the
netelement tp-lib's path gives each fix, by index; null where none) and ``segments``.
"""
from __future__ import annotations

import json
import sys
import time


def main(argv) -> int:
    import tp_lib
    fixes, network = argv[1], argv[2]
    started = time.perf_counter()
    result = tp_lib.calculate_train_path(fixes, "EPSG:4326", network)
    runtime = time.perf_counter() - started
    segments = [s.to_dict() if hasattr(s, "to_dict") else
                {"netelement_id": s.netelement_id, "gnss_start_index": s.gnss_start_index,
                 "gnss_end_index": s.gnss_end_index, "probability": s.probability}
                for s in result.path.segments]
    n = max((int(s["gnss_end_index"]) for s in segments), default=-1) + 1
    element = [None] * n
    for s in segments:
        for k in range(int(s["gnss_start_index"]), int(s["gnss_end_index"]) + 1):
            element[k] = s["netelement_id"]
    print(json.dumps({"runtime_s": runtime, "element": element, "segments": segments,
                      "mode": str(result.mode)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv))
