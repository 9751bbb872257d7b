"""Reading speed of the fix readers: 1 h of 10 Hz NMEA and 1 h of 5 Hz u-blox UBX.

Usage::

    python benchmarks/bench_fix_read.py [--repeat N] [--out FILE]

The files are generated here with the libraries' own builders, not our writers: NMEA
bursts (GGA, RMC, VTG, GSA, GST: 5 sentences per epoch, 36 000 epochs) built and
checksummed by ``pynmea2``; UBX NAV-PVT + NAV-COV pairs (18 000 epochs) built by
``pyubx2.UBXMessage``. The train moves at 20 m/s along a straight from 50.9 N, 4.5 E.
Each reader's time (`gnss_obs.fixes.read_fixes`, format detection and σ completion
included) is the best of ``--repeat`` runs. Writes ``benchmarks/results/fix_read.json``.
"""
from __future__ import annotations

import argparse
import datetime as dt
import json
import platform
import tempfile
import time
from pathlib import Path

import numpy as np
import pynmea2
from pyubx2 import GET, UBXMessage

from gnss_obs.fixes.read import read_fixes
from trackmodel.files import atomic_write_text

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results" / "fix_read.json"
DURATION_S = 3600.0
NMEA_RATE_HZ, UBX_RATE_HZ = 10.0, 5.0
START = dt.datetime(2022, 2, 25, 9, 0, 0)
LEAP_S = 18
SPEED_MPS = 20.0
LAT0_DEG, LON0_DEG = 50.9, 4.5
M_PER_DEG = 111_320.0


def _track(n: int, rate_hz: float):
    t = np.arange(n) / rate_hz
    north = SPEED_MPS * t * np.cos(np.radians(30.0))
    east = SPEED_MPS * t * np.sin(np.radians(30.0))
    return (t, LAT0_DEG + north / M_PER_DEG,
            LON0_DEG + east / (M_PER_DEG * np.cos(np.radians(LAT0_DEG))))


def _ddmm(value: float, width: int) -> str:
    d = int(value)
    return f"{d:0{width}d}{(value - d) * 60:09.6f}"


def write_nmea(path: Path) -> int:
    """1 h of 10 Hz bursts built by pynmea2; returns the epochs written."""
    n = int(DURATION_S * NMEA_RATE_HZ)
    t, lat, lon = _track(n, NMEA_RATE_HZ)
    knots = f"{SPEED_MPS / (1852 / 3600):.3f}"
    lines = []
    for k in range(n):
        stamp = START + dt.timedelta(seconds=float(t[k]))
        tod = stamp.strftime("%H%M%S.") + f"{stamp.microsecond // 10000:02d}"
        la, lo = _ddmm(lat[k], 2), _ddmm(lon[k], 3)
        sentences = (
            pynmea2.RMC("GP", "RMC", (tod, "A", la, "N", lo, "E", knots, "30.0",
                                      stamp.strftime("%d%m%y"), "", "", "R")),
            pynmea2.VTG("GP", "VTG", ("30.0", "T", "", "M", knots, "N", "72.0", "K", "R")),
            pynmea2.GGA("GP", "GGA", (tod, la, "N", lo, "E", "4", "14", "0.7", "54.2", "M",
                                      "45.8", "M", "1.0", "0001")),
            pynmea2.GSA("GP", "GSA", ("A", "3", "01", "02", "03", "04", "05", "06", "", "",
                                      "", "", "", "", "1.2", "0.7", "1.0")),
            pynmea2.GST("GP", "GST", (tod, "0.5", "0.02", "0.015", "30.0", "0.018", "0.016",
                                      "0.03")))
        lines.extend(str(s) for s in sentences)
    path.write_text("\r\n".join(lines) + "\r\n")
    return n


def write_ubx(path: Path) -> int:
    """1 h of 5 Hz NAV-PVT + NAV-COV built by pyubx2; returns the epochs written."""
    n = int(DURATION_S * UBX_RATE_HZ)
    t, lat, lon = _track(n, UBX_RATE_HZ)
    gps0 = (START - dt.datetime(1980, 1, 6)).total_seconds() + LEAP_S
    chunks = []
    for k in range(n):
        stamp = START + dt.timedelta(seconds=float(t[k]))
        itow = int(round(((gps0 + t[k]) % 604_800) * 1000))
        chunks.append(UBXMessage(
            "NAV", "NAV-PVT", GET, iTOW=itow, year=stamp.year, month=stamp.month,
            day=stamp.day, hour=stamp.hour, min=stamp.minute, second=stamp.second,
            nano=stamp.microsecond * 1000, validDate=1, validTime=1, fixType=3, gnssFixOk=1,
            carrSoln=2, numSV=14, lat=float(lat[k]), lon=float(lon[k]), height=100000,
            hMSL=54200, hAcc=14, vAcc=25, velN=17320, velE=10000, velD=0, gSpeed=20000,
            headMot=30.0, sAcc=30, headAcc=0.5, pDOP=1.2).serialize())
        chunks.append(UBXMessage("NAV", "NAV-COV", GET, iTOW=itow, posCovValid=1,
                                 posCovNN=2e-4, posCovNE=0.0, posCovND=0.0, posCovEE=2e-4,
                                 posCovED=0.0, posCovDD=6e-4).serialize())
    path.write_bytes(b"".join(chunks))
    return n


def _best(path: Path, repeat: int) -> tuple[float, int]:
    best, rows = float("inf"), 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        rows = len(read_fixes(path))
        best = min(best, time.perf_counter() - t0)
    return best, rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    out = {"duration_s": DURATION_S, "repeat": args.repeat}
    with tempfile.TemporaryDirectory() as tmp:
        for name, writer, rate in (("nmea", write_nmea, NMEA_RATE_HZ),
                                   ("ubx", write_ubx, UBX_RATE_HZ)):
            path = Path(tmp) / f"fixes.{name}"
            t0 = time.perf_counter()
            epochs = writer(path)
            generate_s = time.perf_counter() - t0
            seconds, rows = _best(path, args.repeat)
            size = path.stat().st_size
            out[name] = {"rate_hz": rate, "epochs": epochs, "fixes_read": rows,
                         "bytes": size, "generate_s": generate_s, "read_s": seconds,
                         "epochs_per_s": epochs / seconds, "mb_per_s": size / seconds / 1e6,
                         "realtime_factor": DURATION_S / seconds}
            print(f"{name}: {epochs} epochs ({size / 1e6:.1f} MB) read in {seconds:.2f} s: "
                  f"{epochs / seconds:,.0f} epochs/s, {DURATION_S / seconds:,.0f}x real time")
    out.update(python=platform.python_version(), machine=platform.machine())
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
