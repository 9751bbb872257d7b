"""`railnav.evaluation.plot_style.warm_up`: drawing a small figure first changes nothing.

Reference: the same figure (an error panel as a run draws it: a line, a σ band, labels, a
legend) written as PNG by a fresh interpreter that draws it first, without the warm-up;
with the warm-up, in another fresh interpreter, the PNG must be the same bytes, the
matplotlib settings the same, and no file written.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]

DRAW = """
import io, json, os, sys
import matplotlib
import numpy as np
from matplotlib.figure import Figure
from railnav.evaluation.plot_style import TIME_LABEL, sigma_band, warm_up
before = {k: repr(v) for k, v in matplotlib.rcParams.items()}
if sys.argv[1] == "warm":
    warm_up()
t = np.linspace(0.0, 1000.0, 2001)
fig = Figure(figsize=(9, 2.7))
ax = fig.add_subplot()
sigma_band(ax, t, 0.0, 0.5 + 0.1 * np.sin(t / 50.0), label="3 sigma")
ax.plot(t, 0.3 * np.sin(t / 30.0), label="along-track error")
ax.set_xlabel(TIME_LABEL)
ax.set_ylabel("along-track error (m)")
ax.legend(loc="upper right")
out = io.BytesIO()
fig.savefig(out, format="png", dpi=110)
after = {k: repr(v) for k, v in matplotlib.rcParams.items()}
print(json.dumps({"png": out.getvalue().hex(), "settings_kept": before == after,
                  "files": sorted(os.listdir("."))}))
"""


def _draw(mode: str, cwd: Path) -> dict:
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, "-c", DRAW, mode], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_warm_up_changes_no_pixel_and_no_setting(tmp_path):
    cold_dir, warm_dir = tmp_path / "cold", tmp_path / "warm"
    cold_dir.mkdir()
    warm_dir.mkdir()
    cold, warm = _draw("cold", cold_dir), _draw("warm", warm_dir)
    assert warm["png"] == cold["png"]
    assert warm["settings_kept"] and cold["settings_kept"]
    assert warm["files"] == [] == cold["files"]
