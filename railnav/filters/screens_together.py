"""The fault screens of a bank's filters at one epoch (issue 15, "banks").

`screen_together` runs `railnav.filters.fault_detection.RowScreen.screen` for several
screens (one per hypothesis of a bank, each with its own channels) at once: the rows of
all are evaluated, their innovation covariances and the influence gains computed stacked
where the shapes agree (`railnav.filters.row_sets.innovation_covariances`,
`railnav.filters.row_sets.influence_gains`) and the fault probabilities of all rows in one
call; each screen's clock-jump test, channel decisions and records are its own, in its
own order. `RowScreen.screen` is the case of one screen, so each screen's statuses,
records and rows are those of its own call, to the bit.
"""
from __future__ import annotations

import numpy as np

from ekf.outliers import fault_probability
from railnav.filters.row_sets import evaluate_rows, influence_gains, innovation_covariances

__all__ = ["screen_together"]


def screen_together(screens, stacked, priors) -> list:
    """`RowScreen.screen` of several screens (a bank's hypotheses) at one epoch, the
    arithmetic of all at once where it stacks (`railnav.filters.row_sets`: innovation
    covariances, gains; the fault probabilities of all rows in one call); each screen's
    channels are stepped by its own rows in their order. `RowScreen.screen` is the case of
    one screen: each screen's statuses, records and rows are those of its own call, to the
    bit.

    Parameters
    ----------
    screens : sequence of RowScreen
    stacked : sequence of tuple
        Each screen's rows ``(observations, sv, kind, modes, groups)``
        (`railnav.filters.fix_rows.stack_epoch_rows`; `RowScreen.screen`'s arguments),
        optionally with the rows' ``inflation`` (`RowScreen.screen`) after them.
    priors : sequence of (ndarray (n,), ndarray (n, n))
        Each screen's prior state and covariance.

    Returns
    -------
    list
        What each screen's `RowScreen.screen` returns, in order.
    """
    evaluated = [evaluate_rows(rows[0], x) for rows, (x, _) in zip(stacked, priors)]
    covariances = innovation_covariances([(H, P, R) for (_, H, R), (_, P)
                                          in zip(evaluated, priors)])
    pending = [screen._start(rows[1], rows[2], x, P, nu, H, S, rows[3], R,
                             rows[5] if len(rows) > 5 else None)
               for screen, rows, (x, P), (nu, H, R), (S, _)
               in zip(screens, stacked, priors, evaluated, covariances)]
    probs = _fault_probabilities([screen.config for screen in screens],
                                 [one["r"] for one in pending])
    for screen, one, prob, rows, (nu, H, R), (_, P) in zip(screens, pending, probs, stacked,
                                                        evaluated, priors):
        screen._rows_used(one, prob, rows[4], H, R, P)
    selected = [screen._influence_rows(one, H, HP) for screen, one, (_, H, _), (_, HP)
                in zip(screens, pending, evaluated, covariances)]
    have = [k for k, rows in enumerate(selected) if rows is not None]
    gains: list = [None] * len(screens)
    for k, K_t in zip(have, influence_gains([selected[k] for k in have])):
        gains[k] = K_t
    return [_finish(screen, one, K_t, rows, x, nu, H, R)
            for screen, one, K_t, rows, (x, _), (nu, H, R)
            in zip(screens, pending, gains, stacked, priors, evaluated)]


def _finish(screen, one: dict, K_t, rows: tuple, x, nu, H, R):
    """A screen's epoch from its gains on: the channels' influence, the record, the
    observer; the used rows (`RowScreen.screen`'s return)."""
    screen._add_influence(one["keys"], one["used"], nu, K_t)
    out = screen._record(one, rows[0], rows[1], rows[2], x, nu, H, R)
    if screen.observer is not None:
        screen.observer(screen.last, rows[2], R, rows[5] if len(rows) > 5 else None)
    return out


def _fault_probabilities(configs, r: list) -> list:
    """`fault_probability` of each screen's normalized innovations ``r²`` (None for a
    screen without a configuration), in one call for the screens of one configuration
    (elementwise: each row's number is its own)."""
    if len(r) == 1:                                 # one screen: nothing to stack
        cfg = configs[0]
        return [None if cfg is None else fault_probability(
            r[0] * r[0], prior=cfg.fault_prior, scale=cfg.fault_scale)]
    out: list = [None] * len(r)
    have = [k for k, cfg in enumerate(configs) if cfg is not None]
    for cfg in dict.fromkeys(configs[k] for k in have):
        members = [k for k in have if configs[k] == cfg]
        found = fault_probability(np.concatenate([r[k] * r[k] for k in members]),
                                  prior=cfg.fault_prior, scale=cfg.fault_scale)
        edges = np.cumsum([0, *(r[k].size for k in members)]).tolist()
        for k, a, b in zip(members, edges[:-1], edges[1:]):
            out[k] = found[a:b]
    return out
