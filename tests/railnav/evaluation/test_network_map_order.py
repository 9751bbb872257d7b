"""The network map draws the same figure whatever Python's string hash seed: the switches'
markers were placed at an arbitrary end of each joint (a set's first member), so two
``railnav network plot`` runs of the same network differed in a few pixels.

Reference: the markers' coordinates drawn in two fresh interpreters with different
``PYTHONHASHSEED`` (the order a set of strings iterates in depends on it).
"""
from __future__ import annotations

import os
import subprocess
import sys

from tests.conftest import DATA, REPO

NETWORK = DATA / "networks" / "brussels_airport"

SNIPPET = f"""
import numpy as np
from matplotlib.figure import Figure
from railnav.evaluation.network_map import _Plane, draw_network
from trackmodel.network_folder import read_network
network = read_network({str(NETWORK)!r})
ax = Figure().subplots()
draw_network(ax, network, _Plane(network), 1.0, labels=False)
dots = [np.r_[line.get_xdata(), line.get_ydata()] for line in ax.lines
        if line.get_marker() == "o" and len(line.get_xdata())]
print(repr(np.array(dots).round(6).tolist()))
"""


def _markers(seed: str) -> str:
    env = {**os.environ, "PYTHONHASHSEED": seed, "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, "-c", SNIPPET], env=env, cwd=REPO,
                          capture_output=True, text=True, check=True)
    return done.stdout


def test_switch_markers_do_not_depend_on_the_hash_seed():
    first = _markers("1")
    assert first.count("[") > 10                     # the network has switches
    assert _markers("2") == first
    assert _markers("3") == first
