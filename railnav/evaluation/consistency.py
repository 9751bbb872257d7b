"""Consistency figures of a set of Monte Carlo runs: is the filter's σ a promise it keeps?

Issue 14's consistency table reports, per case (a scenario run over ``R`` seeds):

* **NEES** (`railnav.evaluation.metrics.error_series`: ``eᵀ P⁻¹ e`` on the ``n`` state
  components whose truth is known) averaged over every stored epoch of every run, with the
  two-sided 99 % interval of the average of ``R`` independent ``χ²_n`` values
  (`ekf.consistency.chi2_band`; Bar-Shalom et al. 2001, §5.4). The epochs of one run are
  strongly correlated (a filter that is wrong stays wrong for its error's correlation
  time), so the interval is the one of the ``R``-run average at one epoch, not of
  ``R·K`` values: wider, and honest about how much independent evidence there is. Also
  the share of epochs whose ``R``-run mean lies inside that interval (≈ 0.99 when
  consistent).
* the share of epochs with ``|error_s| > 3 σ_s`` (2.7e-3 for a Gaussian error),
* the share of epochs with the true ``s`` outside the protection interval
  ``[s_min_m, s_max_m]`` of ``estimates.csv`` where the run has those columns (issue 14,
  part 5), else ``None``,
* the counts of the ``status`` column (issue 14, part 3) where it exists, else ``None``,

each with the number of epochs behind it.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import asdict, dataclass
from typing import Sequence

import numpy as np
import numpy.typing as npt

from ekf.consistency import chi2_band

__all__ = ["RunSeries", "ConsistencySummary", "run_series", "summarize_consistency",
           "NEES_PROBABILITY", "SIGMA_BOUND"]

Array = npt.NDArray[np.float64]

#: Probability of the two-sided NEES interval.
NEES_PROBABILITY = 0.99
#: An along-track error beyond this many σ_s counts as "confidently wrong".
SIGMA_BOUND = 3.0


@dataclass(frozen=True)
class RunSeries:
    """What one run contributes, at its stored epochs (arrays (K,)).

    Attributes
    ----------
    nees : ndarray
        NEES on the known states (NaN where undefined).
    error_s_m : ndarray
        Along-track error, estimate − truth, m.
    sigma_s_m : ndarray
        The filter's σ of ``s``, m.
    truth_s_m : ndarray
        The true ``s``, m.
    s_min_m, s_max_m : ndarray or None
        The protection interval, m (None: the run has no such columns).
    status : ndarray of str or None
        The monitor's status per epoch (None: no such column).
    """

    nees: Array
    error_s_m: Array
    sigma_s_m: Array
    truth_s_m: Array
    s_min_m: Array | None = None
    s_max_m: Array | None = None
    status: npt.NDArray | None = None


def run_series(estimates, *, nees: Array, error_s_m: Array) -> RunSeries:
    """A run's `RunSeries` from its ``estimates`` frame and its errors at the same epochs.

    Parameters
    ----------
    estimates : pandas.DataFrame
        ``estimates.csv``'s columns (``s_m``, ``sigma_s_m``; optional ``s_min_m``,
        ``s_max_m``, ``status``).
    nees : ndarray, shape (K,)
        `railnav.evaluation.metrics.ErrorSeries.nees` (or ``errors.csv``'s column).
    error_s_m : ndarray, shape (K,)
        Along-track error, m (``along_track_m``). The true ``s`` is taken as
        ``s_m − error_s_m`` (exact on the track up to the chord of a curve, ``κ δs²/2``).
    """
    def column(name):
        return estimates[name].to_numpy() if name in estimates else None

    error = np.asarray(error_s_m, dtype=float)
    return RunSeries(nees=np.asarray(nees, dtype=float), error_s_m=error,
                     sigma_s_m=estimates["sigma_s_m"].to_numpy(dtype=float),
                     truth_s_m=estimates["s_m"].to_numpy(dtype=float) - error,
                     s_min_m=column("s_min_m"), s_max_m=column("s_max_m"),
                     status=column("status"))


@dataclass(frozen=True)
class ConsistencySummary:
    """The consistency figures of a case (module docstring); JSON-ready via `to_dict`.

    Attributes
    ----------
    runs : int
    dof : int
        NEES degrees of freedom.
    nees_epochs : int
        Finite NEES values behind `nees_mean`.
    nees_mean : float or None
    nees_interval : (float, float)
        99 % interval of the ``runs``-run mean of ``χ²_dof``.
    nees_mean_inside : bool or None
    share_epochs_nees_inside : float or None
        Share of the epochs (common to all runs) whose ``runs``-run mean NEES is inside.
    sigma_epochs : int
        Epochs with a finite along-track error and σ.
    share_beyond_3sigma : float or None
        Share of them with ``|error_s| > 3 σ_s``.
    max_abs_z : float or None
        Largest ``|error_s| / σ_s``.
    protection_epochs : int
        Epochs with a finite protection interval (0: no run has one).
    share_outside_protection : float or None
    status_counts : dict or None
    """

    runs: int
    dof: int
    nees_epochs: int
    nees_mean: float | None
    nees_interval: tuple[float, float]
    nees_mean_inside: bool | None
    share_epochs_nees_inside: float | None
    sigma_epochs: int
    share_beyond_3sigma: float | None
    max_abs_z: float | None
    protection_epochs: int
    share_outside_protection: float | None
    status_counts: dict[str, int] | None

    def to_dict(self) -> dict:
        """The figures as plain JSON-ready data."""
        out = asdict(self)
        out["nees_interval"] = [float(v) for v in self.nees_interval]
        return out


def _per_epoch_inside(runs: Sequence[RunSeries], band: tuple[float, float]) -> float | None:
    """Share of the epochs common to every run whose mean NEES over the runs is in `band`."""
    k = min(r.nees.size for r in runs)
    if k == 0:
        return None
    stack = np.vstack([r.nees[:k] for r in runs])
    mean = stack.mean(axis=0)
    finite = np.isfinite(mean)
    if not finite.any():
        return None
    return float(np.mean((mean[finite] >= band[0]) & (mean[finite] <= band[1])))


def summarize_consistency(runs: Sequence[RunSeries], *, dof: int,
                          probability: float = NEES_PROBABILITY,
                          sigma_bound: float = SIGMA_BOUND) -> ConsistencySummary:
    """The consistency figures of `runs` (module docstring).

    Parameters
    ----------
    runs : sequence of RunSeries
        One per seed (at least one).
    dof : int
        NEES degrees of freedom (`ErrorSeries.nees_dof`).
    probability : float
        Of the two-sided NEES interval.
    sigma_bound : float
        ``|error_s| > sigma_bound · σ_s`` counts.

    Raises
    ------
    ValueError
        No run, or ``dof < 1``.
    """
    if not runs:
        raise ValueError("summarize_consistency needs at least one run")
    if dof < 1:
        raise ValueError(f"dof must be >= 1, got {dof}")
    band = chi2_band(dof, len(runs), probability)
    nees = np.concatenate([r.nees for r in runs])
    nees = nees[np.isfinite(nees)]
    mean = float(nees.mean()) if nees.size else None
    z = np.concatenate([np.abs(r.error_s_m) / r.sigma_s_m for r in runs])
    z = z[np.isfinite(z)]
    outside, prot_epochs = [], 0
    for r in runs:
        if r.s_min_m is None or r.s_max_m is None:
            continue
        ok = np.isfinite(r.s_min_m) & np.isfinite(r.s_max_m) & np.isfinite(r.truth_s_m)
        prot_epochs += int(ok.sum())
        outside.append((r.truth_s_m[ok] < r.s_min_m[ok]) | (r.truth_s_m[ok] > r.s_max_m[ok]))
    statuses = [r.status for r in runs if r.status is not None]
    counts = dict(Counter(str(s) for st in statuses for s in st)) if statuses else None
    return ConsistencySummary(
        runs=len(runs), dof=int(dof), nees_epochs=int(nees.size), nees_mean=mean,
        nees_interval=band,
        nees_mean_inside=None if mean is None else bool(band[0] <= mean <= band[1]),
        share_epochs_nees_inside=_per_epoch_inside(runs, band), sigma_epochs=int(z.size),
        share_beyond_3sigma=float(np.mean(z > sigma_bound)) if z.size else None,
        max_abs_z=float(z.max()) if z.size else None, protection_epochs=prot_epochs,
        share_outside_protection=float(np.mean(np.concatenate(outside)))
        if prot_epochs else None, status_counts=counts)
