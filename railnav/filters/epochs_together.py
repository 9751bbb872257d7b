"""One epoch's rows of a bank's constrained filters together (issue 15, "banks").

`observations_together` gives what `ConstrainedFilter.observations` gives each filter of a
bank (one per hypothesis, each on its own track, all on one trip's data) for one epoch,
with the work that does not depend on the hypothesis done once and the rest done for
all hypotheses in one pass where it vectorizes:

* the GNSS satellites of the epoch at every hypothesis's receiver guess at once
  (`railnav.filters.common.gnss_rows_together`, `gnss_obs.epoch.prepare_epochs`: the
  transmission states, clocks and measurements shared; flight time, Sagnac, look
  angles, ionosphere and σ elementwise over all guesses);
* the fault screen of all hypotheses' rows (`railnav.filters.screens_together.screen_together`:
  innovation covariances, normalized innovations and fault probabilities stacked; each
  screen's channels stepped in its own order).

Every hypothesis's rows, screen decisions and update rows are those of its own
``observations`` call, to the bit (`tests/railnav/filters/test_epochs_together.py`). The
rows before the screen are each filter's own `ConstrainedFilter.epoch_rows`; filters of
another kind are asked one by one.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from railnav.filters.common import gnss_rows_together
from railnav.filters.constrained import ConstrainedFilter
from railnav.filters.screens_together import screen_together

__all__ = ["observations_together"]

Array = npt.NDArray[np.float64]


def observations_together(filters, index: int, priors) -> list:
    """``filters[k].observations(index, *priors[k])`` for every k (module docstring).

    Parameters
    ----------
    filters : sequence of filter objects
        The bank's filters, in order (constrained filters sharing one GNSS data set are
        done together; any other is asked on its own).
    index : int
        The epoch (an index of the filters' epoch schedule).
    priors : sequence of (ndarray (n,), ndarray (n, n))
        Each filter's prior state and covariance at the epoch.

    Returns
    -------
    list
        Each filter's rows (a list of `ekf.Observation` or an `ekf.EpochRows`), in order.
    """
    filters, priors = list(filters), list(priors)
    together = [k for k, f in enumerate(filters) if type(f) is ConstrainedFilter]
    out: list = [None] * len(filters)
    for k in range(len(filters)):
        if k not in together:
            out[k] = filters[k].observations(index, *priors[k])
    if not together:
        return out
    splits = [filters[k].epoch_split(index) for k in together]
    gnss: dict[int, tuple] = {}
    with_gnss = [j for j, (g, _) in enumerate(splits) if g >= 0]
    for g in sorted({splits[j][0] for j in with_gnss}):
        members = [j for j in with_gnss if splits[j][0] == g]
        builders = [filters[together[j]].rows for j in members]
        found = gnss_rows_together(builders, g, [priors[together[j]][0] for j in members],
                                   [filters[together[j]]._chunk_end for j in members])
        for j, b, rows in zip(members, builders, found):
            gnss[j] = (rows, b.rows_sv[-1], b.rows_kind[-1])
    stacked = []
    for j, k in enumerate(together):
        stacked.append(filters[k].epoch_rows(index, splits[j][1], gnss.get(j), *priors[k]))
    screened = screen_together([filters[k].screen for k in together], stacked,
                               [priors[k] for k in together])
    for k, rows in zip(together, screened):
        out[k] = rows
    return out
