"""Defaults of the GNSS simulator (`gnss_obs.simulate`), each written once here.

The start time of a simulated trip and the 2017 paper's measurement noise. They live in a
module that imports only `gnss_obs.constants`, so that a scenario table
(`railnav.simulation.scenarios`) and the ``railnav`` command line can name them without
importing the simulator (pandas, the ephemeris code). `gnss_obs.simulate` re-exports them.
"""
from __future__ import annotations

import math

from gnss_obs.constants import WEEK_S

__all__ = ["DEFAULT_START_GPS_TIME_S", "PAPER_SIGMA_PR_M", "PAPER_SIGMA_RR_MPS"]

#: Start of a simulated trip when none is given: 2020-11-29 12:40:00 GPST, inside the
#: shipped navigation file (records 09:00-15:00; the shared urban drive's hour). The one
#: default start time of the project (`railnav.simulation.scenarios` uses it).
DEFAULT_START_GPS_TIME_S = 2134 * WEEK_S + 45_600.0
#: The 2017 paper's GNSS noise (SEEDS.md: variances 15 m² and 0.5 (m/s)² at 1 Hz).
PAPER_SIGMA_PR_M = math.sqrt(15.0)
PAPER_SIGMA_RR_MPS = math.sqrt(0.5)
