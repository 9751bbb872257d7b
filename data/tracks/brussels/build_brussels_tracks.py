"""Build the tracks of the four Brussels train logs from the network file, and the excerpts.

    python data/tracks/brussels/build_brussels_tracks.py --data DIR

``DIR`` is the shared folder ``train_network_brussels`` (``network_airport.geojson`` and the
four ``log_*.csv``; see README.md here). For each log the script

1. reads the log with `gnss_obs.fixes.read_fixes` and finds the nearest netelement of every
   fix (in a local east-north plane), keeping fixes within `MATCH_M` of one;
2. keeps the netelements that at least `MIN_RUN` consecutive fixes match (shorter runs are
   the parallel track or a crossover at a switch), each with its direction of travel (the
   sign of the fixes' progress along it);
3. chains consecutive kept netelements through the network's netrelations (navigability
   ``both``, ``AB``, ``BA``): the shortest chain of netelements a train may run, which also
   adds short links no fix matched; of two consecutive netelements that no chain joins
   (the fixes beside a switch matched the other branch for a while), the one with fewer
   fixes is left out (printed);
4. joins their polylines in travel order, cuts the route to the log's extent plus `MARGIN_M`
   at each end, and fits a track with `trackmodel.fit_track` (`TOL_M`, `MIN_RADIUS_M`;
   no height: the network has none), written as ``<log name>.csv`` here.

It also writes the excerpts of `EXCERPTS` (rows copied unchanged) into
``data/fixes/brussels/``. Rebuilding needs no network access; the fits take seconds. Run
from the repository root with the repository on the import path (``PYTHONPATH=.`` unless
railnav is installed from this checkout).
"""
from __future__ import annotations

import argparse
import json
import math
from collections import deque
from pathlib import Path

import numpy as np

from gnss_obs.fixes.read import read_fixes
from trackmodel.fit import fit_track
from trackmodel.io import write_track

HERE = Path(__file__).resolve().parent
EXCERPT_DIR = HERE.parents[1] / "fixes" / "brussels"
LOGS = ("log_28554_L36-A_to_L36C-A", "log_28876_L36-B", "log_29083_L36-A",
        "log_29304_L36-B_to_L36N-B")
#: A fix matches a netelement within this distance, m (fixed rows lie 1-2 m from the
#: centre-line; parallel tracks are 4-6 m apart).
MATCH_M = 5.0
#: A netelement is on the route when this many consecutive fixes match it.
MIN_RUN = 10
#: Track kept beyond the first and last matched fix, m.
MARGIN_M = 150.0
#: Fit tolerance (largest horizontal deviation from the network polyline), m, and the
#: smallest radius (main-line switches and curves are above 300 m).
TOL_M, MIN_RADIUS_M = 0.5, 150.0
#: Excerpts for the tests: (log, first row, number of rows), rows 0-based after the header.
EXCERPTS = (("log_28876_L36-B", 300, 150), ("log_29083_L36-A", 250, 150))
_R_M = 6_371_000.0          # local plane: metres per radian (matching only)


class Plane:
    """A local east-north plane (equirectangular) around a point, for matching only."""

    def __init__(self, lat0_deg: float, lon0_deg: float) -> None:
        self.lat0, self.lon0 = lat0_deg, lon0_deg
        self.k = math.cos(math.radians(lat0_deg))

    def xy(self, lon_deg, lat_deg) -> np.ndarray:
        return np.column_stack([np.radians(np.asarray(lon_deg) - self.lon0) * _R_M * self.k,
                                np.radians(np.asarray(lat_deg) - self.lat0) * _R_M])


def read_network(path: Path):
    """Netelement polylines (lon, lat) by id, and the netrelations."""
    features = json.loads(path.read_text())["features"]
    elements = {f["properties"]["id"]: np.asarray(f["geometry"]["coordinates"], dtype=float)
                for f in features if f["geometry"]["type"] == "LineString"}
    relations = [f["properties"] for f in features if f["geometry"]["type"] == "Point"]
    return elements, relations


def match(points: np.ndarray, elements: dict, plane: Plane):
    """Nearest netelement, distance (m) and position along it (m) of each point."""
    ids, a, b, start = [], [], [], []
    for key, coords in elements.items():
        p = plane.xy(coords[:, 0], coords[:, 1])
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
        ids += [key] * (len(p) - 1)
        a.append(p[:-1]), b.append(p[1:]), start.append(along[:-1])
    a, b, start, ids = np.vstack(a), np.vstack(b), np.concatenate(start), np.array(ids)
    d = b - a
    length2 = np.einsum("ij,ij->i", d, d)
    out_id, out_dist, out_pos = [], [], []
    for q in points:
        t = np.clip(np.einsum("ij,ij->i", q - a, d) / length2, 0.0, 1.0)
        dist = np.hypot(*(a + t[:, None] * d - q).T)
        j = int(np.argmin(dist))
        out_id.append(ids[j]), out_dist.append(dist[j])
        out_pos.append(start[j] + t[j] * math.sqrt(length2[j]))
    return np.array(out_id), np.array(out_dist), np.array(out_pos)


def main_elements(ids, dist, pos) -> list[tuple[tuple[str, int], int]]:
    """((netelement, direction +1/-1), fixes) of the runs of at least `MIN_RUN` fixes."""
    keep = dist <= MATCH_M
    ids, pos = ids[keep], pos[keep]
    runs, start = [], 0
    for i in range(1, len(ids) + 1):
        if i == len(ids) or ids[i] != ids[start]:
            if i - start >= MIN_RUN:
                step = pos[i - 1] - pos[start]
                runs.append(((str(ids[start]), 1 if step >= 0 else -1), i - start))
            start = i
    merged: list = []
    for state, count in runs:
        if merged and merged[-1][0] == state:
            merged[-1] = (state, merged[-1][1] + count)
        else:
            merged.append((state, count))
    return merged


def successors(relations) -> dict:
    """(netelement, direction) -> the (netelement, direction) states a train may enter."""
    out: dict = {}
    for r in relations:
        nav = r.get("navigability", "none")
        a = (r["netelementA"], int(r["positionOnA"]))
        b = (r["netelementB"], int(r["positionOnB"]))
        for (src, src_end), (dst, dst_end), allowed in ((a, b, nav in ("both", "AB")),
                                                         (b, a, nav in ("both", "BA"))):
            if allowed:   # leaving src at src_end: travelling towards that end
                out.setdefault((src, 1 if src_end == 1 else -1), []).append(
                    (dst, 1 if dst_end == 0 else -1))
    return out


def path_between(start, goal, nxt: dict) -> list | None:
    """The states after `start` up to `goal` on the shortest navigable chain (breadth
    first), or None."""
    prev, queue = {start: None}, deque([start])
    while queue and goal not in prev:
        state = queue.popleft()
        for s in nxt.get(state, []):
            if s not in prev:
                prev[s] = state
                queue.append(s)
    if goal not in prev:
        return None
    path, s = [], goal
    while s != start:
        path.append(s)
        s = prev[s]
    return path[::-1]


def chain(runs: list, relations) -> list[tuple[str, int]]:
    """The chained netelements of the route, in order.

    Consecutive runs must be joined by a navigable chain. Where one is not (the fixes
    beside a switch matched the other branch for a while), the run with fewer fixes is
    left out (printed); then the chain fills the links between the kept runs.
    """
    nxt = successors(relations)
    kept = [runs[0]]
    for state, count in runs[1:]:
        if path_between(kept[-1][0], state, nxt) is not None:
            kept.append((state, count))
        elif count > kept[-1][1] and (len(kept) == 1 or path_between(kept[-2][0], state, nxt)
                                      is not None):
            print(f"  {kept[-1][0][0]} left out ({kept[-1][1]} fixes; {state[0]} has {count})")
            kept[-1] = (state, count)
        else:
            print(f"  {state[0]} left out ({count} fixes): not reachable from {kept[-1][0][0]}")
    full = [kept[0][0]]
    for state, _ in kept[1:]:
        full += path_between(full[-1], state, nxt)
    return full


def route_polyline(elements: dict, states, plane: Plane, first_xy, last_xy) -> np.ndarray:
    """The chained netelements' (lon, lat) in travel order, cut to the log plus margins."""
    parts = [elements[e][:: d] for e, d in states]
    coords = np.vstack([parts[0]] + [p[1:] if np.allclose(p[0], q[-1]) else p
                                     for q, p in zip(parts[:-1], parts[1:])])
    xy = plane.xy(coords[:, 0], coords[:, 1])
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    s0 = along[np.argmin(np.hypot(*(xy - first_xy).T))] - MARGIN_M
    s1 = along[np.argmin(np.hypot(*(xy - last_xy).T))] + MARGIN_M
    return coords[(along >= s0) & (along <= s1)]


def build(data: Path, name: str, elements, relations) -> str:
    """Fit and write the track of one log; returns a one-line summary."""
    table = read_fixes(data / f"{name}.csv").table
    plane = Plane(float(table["lat_deg"].median()), float(table["lon_deg"].median()))
    xy = plane.xy(table["lon_deg"], table["lat_deg"])
    ids, dist, pos = match(xy, elements, plane)
    states = chain(main_elements(ids, dist, pos), relations)
    on = np.flatnonzero(dist <= MATCH_M)
    coords = route_polyline(elements, states, plane, xy[on[0]], xy[on[-1]])
    fit = fit_track(np.radians(coords[:, 1]), np.radians(coords[:, 0]), tol_m=TOL_M,
                    min_radius_m=MIN_RADIUS_M)
    chained = " ".join(f"{e}{'+' if d > 0 else '-'}" for e, d in states)
    write_track(fit.track, HERE / f"{name}.csv", comments=[
        f"route of {name} chained from network_airport.geojson: {chained}",
        f"built by data/tracks/brussels/build_brussels_tracks.py; {fit.track.length_m:.1f} m, "
        f"{len(fit.track.sections)} sections, max deviation {fit.max_horizontal_m:.3f} m"])
    return f"{name}: {len(states)} netelements, {fit.track.length_m:.0f} m, " \
           f"{len(fit.track.sections)} sections, max deviation {fit.max_horizontal_m:.3f} m"


def write_excerpts(data: Path) -> None:
    """Copy the rows of `EXCERPTS` unchanged (header + rows)."""
    EXCERPT_DIR.mkdir(parents=True, exist_ok=True)
    for name, first, count in EXCERPTS:
        lines = (data / f"{name}.csv").read_text().splitlines(keepends=True)
        (EXCERPT_DIR / f"{name}_excerpt.csv").write_text(
            "".join(lines[:1] + lines[1 + first:1 + first + count]))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True,
                        help="the train_network_brussels folder (network + logs)")
    args = parser.parse_args(argv)
    elements, relations = read_network(args.data / "network_airport.geojson")
    for name in LOGS:
        print(build(args.data, name, elements, relations))
    write_excerpts(args.data)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
