"""What a network run produces (`railnav.navigation.network_navigator.navigate_network`).

`NetworkResult` keeps, for every cycle, the most probable netelement (the one holding
the most of the position's probability, each hypothesis's Gaussian along ``s`` shared
out over the elements it covers: `railnav.navigation.element_shares`), that probability,
the most probable hypothesis on it (its state and covariance) and the mixture of all
hypotheses on that element along it (moment-matched offset and σ; when no hypothesis's
mean is on it, the joint just passed and the σ_s of the hypothesis holding most there);
the live hypotheses once per
`NetworkNavConfig.hypotheses_every_s`; the innovations of the most probable hypothesis at
each epoch (``innovations.csv``: `railnav.navigation.network_innovations`); and the final
hypotheses with their paths. From these:

* `NetworkResult.estimates`: the ``estimates.csv`` table of the most probable hypothesis
  (its filter's columns, `railnav.navigation.result.estimates_frame`) plus ``netelement``,
  ``netelement_offset_m`` (from the element's first coordinate), ``direction`` (+1 towards
  its last coordinate), ``netelement_probability``, ``mixture_offset_m`` and
  ``mixture_sigma_m`` (the mixture on that element: meaningful where one element holds a
  Gaussian sum along ``s``), and ``hypotheses`` (the live count); in runs with position
  fixes or GNSS observations also ``status`` (``ok``, ``degraded``, ``lost``: whether any
  live hypothesis agrees with the fixes, or with the GNSS epochs' own single-point fixes,
  the test of `railnav.navigation.spawning`, and whether the rows reported are rejected
  more often, or disagree more, than a fault-free navigator's, and its pseudo-observation
  too, `railnav.navigation.network_status`);
* `NetworkResult.hypotheses`: ``hypotheses.csv``;
* `NetworkResult.route_frame`: ``route.csv``, the route of the final most probable
  hypothesis (its path without the visits across a joint and back that never went surely
  across it: `railnav.navigation.route_path.route`), each element with entry and exit
  times, the probability of the final mixture that its route went through that element
  (``probability``) and the share the element held while the train was on it
  (``mean_probability``, ``min_probability``);
* `NetworkResult.combined`: a `railnav.navigation.result.NavigationResult` of the
  estimates and innovations, for the writers, plots and scores of single-track runs.

Estimates are at the cycle ends (each epoch, and every `railnav.navigation.loop.MAX_CHUNK_S`
without one), not at ``config.output_rate_hz``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd

from ekf.bank import logsumexp
from ekf.packing import pack_sym
from railnav.navigation.element_shares import element_shares
from railnav.navigation.hypotheses import most_probable, normalized_weights
from railnav.navigation.statuses import status_at
from railnav.navigation.network_innovations import innovation_frame, noise_factors
from railnav.navigation.network_status import (combined_status_records, pseudo_nis,
                                                pseudo_records, row_records)
from railnav.navigation.result import NavigationResult, estimates_frame
from railnav.navigation.route_path import route

__all__ = ["NetworkRecorder", "NetworkResult", "NETWORK_COLUMNS"]

Array = npt.NDArray[np.float64]

#: Columns a network run adds to ``estimates.csv``.
NETWORK_COLUMNS = ("netelement", "netelement_offset_m", "direction",
                   "netelement_probability", "mixture_offset_m", "mixture_sigma_m",
                   "hypotheses")


def _offset(tracks, h, where=None) -> float:
    """The hypothesis's offset from its element's first coordinate, m (`where`: its
    ``h.where()`` when known)."""
    element, orientation, s = h.where() if where is None else where
    return float(tracks.offset_m(element, orientation, s))


def _mixture_offset(hyps, w: Array, tracks, element: str, spots=None) -> tuple[float, float]:
    """Moment-matched offset (m, from the element's first coordinate) and σ of the
    hypotheses on `element` (`spots`: their ``where()``, when known)."""
    spots = [h.where() for h in hyps] if spots is None else spots
    on = [k for k, spot in enumerate(spots) if spot[0] == element]
    if len(on) == 1:        # the general formula's numbers: ww = [1.0], off - mean = 0
        h = hyps[on[0]]
        i_s = h.index("s")
        return _offset(tracks, h, spots[on[0]]), float(np.sqrt(h.P[i_s, i_s] + 0.0))
    ww = w[on] / w[on].sum()
    off = np.array([_offset(tracks, hyps[k], spots[k]) for k in on])
    var = np.array([hyps[k].P[hyps[k].index("s"), hyps[k].index("s")] for k in on])
    mean = float(ww @ off)
    return mean, float(np.sqrt(ww @ (var + (off - mean) ** 2)))


class NetworkRecorder:
    """Collects the cycles of a network run (module docstring)."""

    def __init__(self, tracks, factory, nav, *, start_gps_time_s: float) -> None:
        self.tracks, self.factory, self.nav = tracks, factory, nav
        self.start_gps_time_s = float(start_gps_time_s)
        self.rows: list[dict] = []
        self.x: list[Array] = []
        self.P: list[Array] = []
        self.keys: list[tuple[str, int]] = []
        self.element_probability: list[dict] = []
        self.element_log_likelihood: list[dict] = []
        self._log_lik: dict = {}
        self.hyp_rows: list[dict] = []
        self.innov: list[pd.DataFrame] = []
        self.restarts: list[float] = []
        #: ``(time_s, count)`` of the spawns (`railnav.navigation.spawning`).
        self.spawns: list[tuple[float, int]] = []
        #: The spawner's test per fix epoch (`railnav.navigation.spawning.Spawner.frame`).
        self.status_records = None
        #: ``(time_s, NIS sum, degrees of freedom)`` of the most probable hypothesis's
        #: pseudo-observation in each cycle (`railnav.navigation.network_status`).
        self.pseudo: list[tuple[float, float, int]] = []
        self.steps = 0
        self._next_hyp_s = -np.inf
        self._last: list = []

    def epoch(self, time_s: float, hyps, outcome, log_lik=None) -> None:
        """Record a cycle's screened epoch, of the most probable hypothesis (after the
        evidence, before branching), its filter steps and each netelement's evidence
        (`log_lik`, each hypothesis's, after the reweighting: `_element_log_likelihoods`)."""
        self.steps += outcome.steps
        self._log_lik = {} if log_lik is None else _element_log_likelihoods(hyps, log_lik)
        best = most_probable(hyps)
        if outcome.innov_c and len(outcome.innov_c) == len(hyps):
            self.pseudo.append((time_s, *pseudo_nis(outcome.innov_c[best],
                                                    outcome.S_c[best])))
        if outcome.screens is not None:
            factors = noise_factors(hyps[best].filt)
            screens = outcome.screens
            if isinstance(screens, list):   # else a stepper's stacked screens, read-only:
                screens, best = [screens[best]], 0  # their EpochScreen made in `result`
            self.innov.append((screens, best, time_s, factors))

    def cycle(self, time_s: float, hyps, *, evidence_rows: int, merges: int,
              pruned: float) -> None:
        """Record a cycle's hypotheses after branching, merging and pruning."""
        w = normalized_weights(hyps)
        spots = [h.where() for h in hyps]             # (element, orientation, s) of each
        shares = [element_shares(h, self.tracks) for h in hyps]
        per_element: dict[str, float] = {}
        for parts, wk in zip(shares, w.tolist()):
            for e, _, share, _ in parts:
                per_element[e] = per_element.get(e, 0.0) + wk * share
        element = max(per_element, key=per_element.get)
        on = [k for k, spot in enumerate(spots) if spot[0] == element]
        if on:
            best = on[int(np.argmax(w[on]))] if len(on) > 1 else on[0]
            spot = spots[best]
            mean, sigma = _mixture_offset(hyps, w, self.tracks, element, spots)
        else:           # no mean on it: the hypothesis with most mass there, at its end
            best, spot = _most_on(shares, w, element)
            mean = _offset(self.tracks, hyps[best], spot)
            i_s = hyps[best].index("s")
            sigma = float(np.sqrt(hyps[best].P[i_s, i_s]))
        h = hyps[best]
        v = float(h.x[h.index("v")])
        self.rows.append({"time_s": time_s, "netelement": element,
                          "netelement_offset_m": _offset(self.tracks, h, spot),
                          "direction": int(spot[1] * (1 if v >= 0 else -1)),
                          "netelement_probability": per_element[element],
                          "mixture_offset_m": mean, "mixture_sigma_m": sigma,
                          "hypotheses": len(hyps), "evidence_rows": evidence_rows,
                          "merges": merges, "pruned_probability": pruned})
        self.x.append(h.x.copy())
        self.P.append(pack_sym(h.P))
        self.keys.append(h.pieces)
        self.element_probability.append(per_element)
        self.element_log_likelihood.append(self._log_lik)
        self._last = list(hyps)
        if time_s >= self._next_hyp_s:
            self._next_hyp_s = time_s + self.nav.hypotheses_every_s
            self.hyp_rows.extend(_hypothesis_rows(hyps, w, time_s, self.tracks))

    def result(self, network, config, nav, hyps, *, outages, runtime_s: float
               ) -> "NetworkResult":
        """The finished run (`hyps` empty when every hypothesis died with no fix left to
        start again from: the last recorded ones stand for the end)."""
        hyps = hyps or self._last
        w = normalized_weights(hyps)
        final = [{"id": h.id, "element": h.element, "orientation": h.orientation,
                  "probability": float(wk), "path": h.path} for h, wk in zip(hyps, w)]
        table = pd.DataFrame(self.rows)
        innovations = innovation_frame([(screens[best], time_s) for screens, best, time_s, _
                                        in self.innov], self.start_gps_time_s,
                                       [factors for *_, factors in self.innov])
        return NetworkResult(
            network=network, tracks=self.tracks, factory=self.factory, config=config,
            nav=nav, start_gps_time_s=self.start_gps_time_s, runtime_s=float(runtime_s),
            cycles=table, x=np.array(self.x), P=np.array(self.P), keys=tuple(self.keys),
            element_probability=tuple(self.element_probability),
            element_log_likelihood=tuple(self.element_log_likelihood),
            hypotheses=pd.DataFrame(self.hyp_rows),
            innovations=innovations,
            final=tuple(final), outages=tuple(tuple(o) for o in outages),
            restarts=tuple(self.restarts), n_steps=int(self.steps),
            spawns=tuple(self.spawns), status_records=combined_status_records(
                self.status_records, row_records(innovations, config, _off_network(
                    self.status_records)),
                pseudo_records(self.pseudo, config)))


def _off_network(spawn: pd.DataFrame | None) -> Array:
    """The times of the fix epochs whose fix is off the network (`Spawner.frame`)."""
    if spawn is None or "fix_off_network" not in spawn:
        return np.zeros(0)
    return spawn.loc[spawn["fix_off_network"].astype(bool), "time_s"].to_numpy(dtype=float)


def _most_on(shares, w: Array, element: str) -> tuple[int, tuple[str, int, float]]:
    """The hypothesis holding the most probability on `element` and the point of it
    nearest its mean (`railnav.navigation.element_shares`)."""
    mass = [sum(p for e, _, p, _ in parts if e == element) * wk
            for parts, wk in zip(shares, w.tolist())]
    best = int(np.argmax(mass))
    e, o, _, x = max((part for part in shares[best] if part[0] == element),
                     key=lambda part: part[2])
    return best, (e, o, x)


def _element_log_likelihoods(hyps, log_lik) -> dict[str, float]:
    """Each netelement's log-likelihood of a cycle's evidence: that of the mixture of its
    hypotheses at their predicted weights, ``log Σ_k w_k⁺ − log Σ_k w_k⁺ / L_k`` from the
    reweighted ``log w_k⁺ = log w_k⁻ + log L_k`` (one hypothesis: its own ``log L``)."""
    post: dict[str, list[float]] = {}
    prior: dict[str, list[float]] = {}
    for h, ll in zip(hyps, np.asarray(log_lik, dtype=float).tolist()):
        post.setdefault(h.element, []).append(h.log_weight)
        prior.setdefault(h.element, []).append(h.log_weight - ll)
    return {e: _logsumexp(post[e]) - _logsumexp(prior[e]) for e in post}


def _logsumexp(values: list[float]) -> float:
    """`ekf.bank.logsumexp` of a list, one value without NumPy (``log e^a = a``: the same
    number, ``a + 0``)."""
    if len(values) == 1:
        return values[0] + 0.0
    return float(logsumexp(np.array(values)))


def _hypothesis_rows(hyps, w: Array, time_s: float, tracks) -> list[dict]:
    out = []
    for h, wk in zip(hyps, w):
        i_s, i_v = h.index("s"), h.index("v")
        v = float(h.x[i_v])
        element, orientation, _ = h.where()
        out.append({"time_s": time_s, "id": h.id, "parent": h.parent, "netelement": element,
                    "orientation": orientation,
                    "direction": int(orientation * (1 if v >= 0 else -1)),
                    "netelement_offset_m": _offset(tracks, h),
                    "s_m": h.s_m, "sigma_s_m": float(np.sqrt(h.P[i_s, i_s])),
                    "speed_mps": v, "sigma_speed_mps": float(np.sqrt(h.P[i_v, i_v])),
                    "probability": float(wk)})
    return out


@dataclass(frozen=True, eq=False)
class NetworkResult:
    """A network run (module docstring). ``cycles`` has one row per cycle (the network
    columns, ``evidence_rows``, ``merges``, ``pruned_probability``); ``x``
    and ``P`` (packed) the most probable hypothesis's state there (``s`` along its own
    track), ``keys`` the pieces of that track; ``element_probability`` and
    ``element_log_likelihood`` per cycle, by netelement, the probability and the cycle's
    evidence (log-likelihood, 0 without any); ``final`` the last hypotheses (``id,
    element, orientation, probability, path``); ``restarts`` the times every hypothesis had
    died, ``spawns`` ``(time_s, count)`` of the hypotheses started from a fix that no live
    one agreed with (`railnav.navigation.spawning`)."""

    network: object
    tracks: object
    factory: object
    config: object
    nav: object
    start_gps_time_s: float
    runtime_s: float
    cycles: pd.DataFrame
    x: Array
    P: Array
    keys: tuple
    element_probability: tuple
    hypotheses: pd.DataFrame
    innovations: pd.DataFrame
    final: tuple
    outages: tuple
    restarts: tuple = ()
    n_steps: int = 0
    element_log_likelihood: tuple = ()
    spawns: tuple = ()
    status_records: pd.DataFrame | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def time_s(self) -> Array:
        """Cycle end times, s from the trip start."""
        return self.cycles["time_s"].to_numpy(dtype=float)

    @property
    def estimates(self) -> pd.DataFrame:
        """The ``estimates.csv`` table (module docstring)."""
        if "estimates" not in self._cache:
            self._cache["estimates"] = self._estimates()
        return self._cache["estimates"]

    def _estimates(self) -> pd.DataFrame:
        t = self.time_s
        parts = []
        index = {key: k for k, key in enumerate(dict.fromkeys(self.keys))}
        code = np.array([index[key] for key in self.keys])
        for key, k in index.items():
            rows = np.flatnonzero(code == k)
            filt = self.factory.template(key)
            frame = estimates_frame(filt, t[rows], self.x[rows], self.P[rows],
                                    start_gps_time_s=self.start_gps_time_s)
            parts.append(frame.set_index(rows))
        out = pd.concat(parts).sort_index()
        for name in NETWORK_COLUMNS:
            out[name] = self.cycles[name].to_numpy()
        if self.status_records is not None:          # runs with the spawn test
            out["status"] = status_at(self.status_records, t)
        return out.reset_index(drop=True)

    def route_frame(self) -> pd.DataFrame:
        """``route.csv`` (module docstring)."""
        routes = [route(f["path"]) for f in self.final]
        best = routes[max(range(len(routes)), key=lambda k: self.final[k]["probability"])]
        t = self.time_s
        rows = []
        for k, (element, orientation, entry, *_) in enumerate(best):
            leave = best[k + 1].entry_time_s if k + 1 < len(best) else float(t[-1])
            last = k + 1 == len(best)
            share = [p.get(element, 0.0) for p, tk in zip(self.element_probability, t)
                     if entry - 1e-9 <= tk and (tk < leave - 1e-9 or last)]
            passed = sum(f["probability"] for f, r in zip(self.final, routes)
                         if element in {p.element for p in r})
            rows.append({"netelement": element, "orientation": orientation,
                         "entry_time_s": float(entry), "exit_time_s": float(leave),
                         "entry_gps_time_s": float(entry) + self.start_gps_time_s,
                         "exit_gps_time_s": float(leave) + self.start_gps_time_s,
                         "probability": float(passed),
                         "mean_probability": float(np.mean(share)) if share else np.nan,
                         "min_probability": float(np.min(share)) if share else np.nan})
        return pd.DataFrame(rows)

    def route_summary(self) -> dict:
        """``summary.json["route"]``: the route's elements and probabilities, the final
        hypotheses, how many lived (median, max) and what pruning dropped."""
        route = self.route_frame()
        cyc = self.cycles
        return {"netelements": route["netelement"].tolist(),
                "probabilities": [round(float(p), 6) for p in route["probability"]],
                "final_probability": float(max(f["probability"] for f in self.final)),
                "final_hypotheses": len(self.final), "cycles": int(len(cyc)),
                "hypotheses_median": float(cyc["hypotheses"].median()),
                "hypotheses_max": int(cyc["hypotheses"].max()),
                "pruned_probability_total": float(cyc["pruned_probability"].sum()),
                "merges": int(cyc["merges"].sum()), "restarts": list(self.restarts),
                "spawns": [list(sp) for sp in self.spawns],
                "max_hypotheses": self.nav.max_hypotheses,
                "prune_probability": self.nav.prune_probability,
                "crossing_rate_per_s": self.nav.crossing_rate_per_s,
                "runtime_s": self.runtime_s}

    def combined(self) -> NavigationResult:
        """The estimates and innovations as a `NavigationResult` (``raw`` is None: no one
        filter ran the whole trip; ``filter_object`` the last most probable one's
        template, whose ``s`` is along its own element)."""
        est = self.estimates
        filt = self.factory.template(self.keys[-1])
        return NavigationResult(
            filter=self.config.filter, layout=filt.layout,
            start_gps_time_s=self.start_gps_time_s, time_s=self.time_s, x=self.x, P=self.P,
            estimates=est, innovations=self.innovations, nis_continuous_mean=float("nan"),
            nis_continuous_dof=0, outages=self.outages, runtime_s=self.runtime_s,
            n_steps=self.n_steps, n_epochs=int(self.innovations["epoch"].nunique())
            if len(self.innovations) else 0, raw=None, filter_object=None, left_track=None,
            monitor=self.status_records)
