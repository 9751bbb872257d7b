r"""The slow part of the code errors: an along-track bias shared by an epoch's position rows.

Urban pseudorange errors have two parts (the shared urban drive, GPS L1 at the PPK
reference; ``benchmarks/bench_pseudorange_sigma.py``, ``code_bias`` in its JSON):

* a fast part, code multipath that decorrelates within seconds or metres: the gnss-only
  filter takes it as white noise of inflated variance
  (`railnav.filters.gnss_only_noise.correlation_inflation`);
* a slow part that lasts minutes: a street's multipath environment seen from the same
  side, the broadcast orbits and clocks, what the atmosphere models leave. An average over
  epochs does not reduce it. A filter that takes the rows as independent, even inflated,
  ends with a σ_s below its error (on the drive's pieces 101 of 952 epochs were beyond
  3σ_s, ``benchmarks/results/real_pieces.json``).

**Model.** The slow part of one epoch's position rows moves the single-epoch solution on the
track by ``σ_e b``, with:

* ``σ_e = k σ_1``: σ_1 is the along-track σ of the epoch's rows solved alone for ``s`` and
  the receiver clocks with their white variances (`snapshot_variance_s`); k is
  `CodeBiasConfig.sigma`;
* ``b``, the state ``code_bias``: a first-order Gauss–Markov process of unit variance and
  correlation time τ_b (`CodeBiasConfig.time_s`; `railnav.filters.gnss_only_model`).

The pseudorange rows are those of a receiver at ``s + σ_e b`` (`code_bias_rows`, `with_scale`;
the range-rate rows keep the receiver at ``s``). What one epoch measures is then the rows'
apparent position, ``s + σ_e b``. The filter's σ_s stays near σ_e however many epochs it
averages. It falls below σ_e only where something other than the code rows tells ``s``:
the Doppler rows through the track's curvature, an odometer, a balise. Code fixes
(single-point, DGPS, with ``FixModelConfig.correlated_code_errors``) are the same errors
already solved. Their position rows get ``σ_e = k σ_along`` (`code_bias_fix_position`),
σ_along the fix's own along-track σ.

A run's first fix (the start, a restart) is such a solution too. Its along-track variance
gets σ_e² (`start_variance_m2`), so that the start does not count as independent
information against the bias. The correlation between the start fix's slow error and the
rows' is not modelled. It is 0.82 between the single-point fix's and the constrained
single-epoch solution's along-track errors (calibration and held-out pieces alike). With it
(``P_sb = −0.82 k σ``), the filter took the constrained rows' apparent position at a start
over the fix, and on the held-out pieces the rows were the worse of the two at the start
(leg 1 part 4: 6.4 m behind against the fix's 1.8 m): the maxima of parts 4 and 5 rose
above the single-point maxima (7.04 and 3.45 m against 6.44 and 3.11 m).

**Calibration** (leg 1 parts 1-3 of ``benchmarks/bench_real_pieces.py``, the drive's first
3 minutes; ``benchmarks/bench_code_bias.py``, ``benchmarks/results/code_bias.json``). On the
filter's rows at the reference position, the single-epoch along-track error is
1.14 σ_1 RMS over 174 epochs, 0.98 σ_1 of it in its centred 31-s mean (the slow part; on
the held-out pieces 1.30 and 1.10 over 335 epochs). Hence k = 1; the rows' own variance
stands for the fast part. Its autocorrelation along leg 1 falls to 0.2 at 20 s and then
swings with the street's direction (−0.4 at 60 s, +0.5 at 90 s): the same satellites'
errors seen along another street. τ_b = 300 s, longer than the window, keeps the bias
through the turns; a decorrelation at each turn of the track (rate ``|κ v|``/rad) was
tried and changed no piece's figures.

References: state augmentation for a coloured (time-correlated) measurement error,
A. E. Bryson and D. E. Johansen, "Linear filtering for time-varying systems using
measurements containing colored noise", *IEEE Trans. Automatic Control* 10(1), 1965.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import MeasurementModel
from railnav.errors import ConfigError
from railnav.filters.gnss_only_model import CODE_BIAS_STATE
from railnav.filters.gnss_rows import (
    TRACK_ROW_NAMES,
    GnssRows,
    compose_gnss_rows,
    track_position,
)

__all__ = ["CodeBiasConfig", "code_bias_rows", "code_bias_fix_position", "with_scale",
           "snapshot_variance_s", "start_variance_m2", "apparent_variance",
           "CODE_BIAS_ROWS_NAME", "FIX_POSITION_MODEL"]

Array = npt.NDArray[np.float64]

_N_TRACK = len(TRACK_ROW_NAMES)
#: Prefix of the code-bias row models' names (``<prefix>_pseudorange``: the monitor's
#: snapshot fix takes every ``*_pseudorange`` model, `railnav.navigation.track_fixes`).
CODE_BIAS_ROWS_NAME = "track_code_bias"
#: The fix position rows' model name (`railnav.filters.fix_rows.build_fix_rows`'s, kept:
#: `railnav.navigation.snapshot.SNAPSHOT_FIX_MODEL`).
FIX_POSITION_MODEL = "fix_position"
#: The position rows that carry the state: their models' names.
_POSITION_MODELS = (f"{CODE_BIAS_ROWS_NAME}_pseudorange", FIX_POSITION_MODEL)


@dataclass(frozen=True)
class CodeBiasConfig:
    """The slow code error's model (module docstring).

    Used by the gnss-only filter when its pseudoranges are taken as correlated
    (``NavigatorConfig.pseudorange_correlation_s`` > 0: with white errors, a simulated trip,
    there is no slow part either).

    Parameters
    ----------
    sigma : float
        k: the slow error's σ along the track in units of the epoch's single-epoch σ
        (dimensionless, >= 0; 0: off). Default 1 (calibration: 0.98 slow, 1.14 in all).
    time_s : float
        τ_b: its correlation time, s (> 0). Default 300 s.
    """

    sigma: float = 1.0
    time_s: float = 300.0

    def __post_init__(self) -> None:
        if not (isinstance(self.sigma, (int, float)) and math.isfinite(self.sigma)
                and self.sigma >= 0.0):
            raise ConfigError(f"code_bias.sigma must be a finite number >= 0, "
                              f"got {self.sigma!r}")
        if not (isinstance(self.time_s, (int, float)) and math.isfinite(self.time_s)
                and self.time_s > 0.0):
            raise ConfigError(f"code_bias.time_s must be a finite number > 0, "
                              f"got {self.time_s!r}")

    @property
    def enabled(self) -> bool:
        """Whether the model is on (``sigma`` > 0)."""
        return self.sigma > 0.0


@functools.lru_cache(maxsize=None)
def code_bias_rows(layout: StateLayout, isb_names: tuple[str, ...] = ()) -> GnssRows:
    """Pseudorange and range-rate rows of a receiver at ``s + σ_e b`` on the track.

    `railnav.filters.gnss_rows.compose_gnss_rows` with the track receiver of
    `railnav.filters.gnss_rows.build_gnss_rows` evaluated at ``s + σ_e b``: each row's
    receiver part is the track part (`railnav.filters.gnss_rows.track_rows`) followed by
    σ_e (m; `with_scale`). The velocity is ``v t(s + σ_e b)``: the range-rate rows are given
    σ_e = 0, the receiver at ``s``.

    Parameters
    ----------
    layout : ekf.StateLayout
        With ``s``, ``v``, the clock states, `isb_names` and ``code_bias``.
    isb_names : tuple of str

    Returns
    -------
    railnav.filters.gnss_rows.GnssRows
    """
    i_s, i_v, i_b = layout.index("s"), layout.index("v"), layout.index(CODE_BIAS_STATE)

    def receiver(x: ca.SX, part: ca.SX) -> tuple[ca.SX, ca.SX]:
        r_e, t_e = track_position(part[:_N_TRACK], x[i_s] + part[_N_TRACK] * x[i_b])
        return r_e, x[i_v] * t_e

    return compose_gnss_rows(layout, isb_names, receiver, n_part=_N_TRACK + 1,
                             name=CODE_BIAS_ROWS_NAME)


def with_scale(p: Array, scale_m: float) -> Array:
    """Row parameters of `code_bias_rows` from those of the plain track rows.

    Parameters
    ----------
    p : ndarray, shape (m, k)
        `railnav.filters.gnss_rows.pseudorange_parameters` or ``range_rate_parameters``
        (the track part first).
    scale_m : float
        σ_e, m.

    Returns
    -------
    ndarray, shape (m, k + 1)
        σ_e inserted after the track part.
    """
    out = np.empty((p.shape[0], p.shape[1] + 1))
    out[:, :_N_TRACK] = p[:, :_N_TRACK]
    out[:, _N_TRACK] = scale_m
    out[:, _N_TRACK + 1:] = p[:, _N_TRACK:]
    return out


def snapshot_variance_s(H: Array, variances: Array, i_s: int, clock_columns) -> float:
    """σ_1²: the along-track variance of one epoch's rows solved alone by weighted least
    squares for ``s`` and the receiver clocks (the other states held).

    Parameters
    ----------
    H : ndarray, shape (m, n)
        The rows' Jacobian at the prior.
    variances : ndarray, shape (m,)
        Their noise variances (white: not inflated), m².
    i_s : int
        Column of ``s``.
    clock_columns : sequence of int
        Columns of the clock bias and inter-system biases (those with a nonzero entry are
        unknowns).

    Returns
    -------
    float
        ``[(Aᵀ W A)⁻¹]_ss``, m²; NaN with fewer rows than unknowns or a singular geometry.
    """
    cols = [i_s] + [c for c in clock_columns if np.count_nonzero(H[:, c])]
    if H.shape[0] < len(cols):
        return math.nan
    A = H[:, cols] / np.sqrt(np.asarray(variances, dtype=float))[:, None]
    try:
        variance = float(np.linalg.solve(A.T @ A, np.eye(len(cols))[:, 0])[0])
    except np.linalg.LinAlgError:
        return math.nan
    return variance if math.isfinite(variance) and variance > 0.0 else math.nan


@functools.lru_cache(maxsize=None)
def code_bias_fix_position(layout: StateLayout) -> MeasurementModel:
    """The fix position rows of `railnav.filters.fix_rows.build_fix_rows` at
    ``s + σ_e b``.

    Row parameters: those of the plain rows (the track part, the axis in ECEF), then σ_e (m).
    The model's name is the plain rows' (``fix_position``: the monitor's snapshot fix takes
    the epoch's rows by it, `railnav.navigation.snapshot.SNAPSHOT_FIX_MODEL`).
    """
    x = ca.SX.sym("x", layout.size)
    s, b = x[layout.index("s")], x[layout.index(CODE_BIAS_STATE)]
    p = ca.SX.sym("p", _N_TRACK + 4)
    r_e, _ = track_position(p[:_N_TRACK], s + p[_N_TRACK + 3] * b)
    along = ca.dot(p[_N_TRACK:_N_TRACK + 3], r_e - p[1:4])
    return MeasurementModel.from_expression(x, p, along, FIX_POSITION_MODEL)


def start_variance_m2(sigma_s_m: float, config: CodeBiasConfig) -> float:
    """The variance a start fix's along-track σ (`sigma_s_m`, m) gets for its slow part:
    ``(k σ)²``, m² (module docstring)."""
    return (config.sigma * float(sigma_s_m)) ** 2


def apparent_variance(observations, x: Array, P: Array, i_s: int, i_bias: int) -> float:
    """The prior's variance of the rows' apparent position ``s + σ_e b``: what one epoch's
    position rows solved alone measure (the monitor's snapshot fix,
    `railnav.navigation.monitor`), not ``s``.

    σ_e is read from the rows themselves: ``∂h/∂b = σ_e ∂h/∂s`` in each position row
    (`code_bias_rows`, `code_bias_fix_position`), taken as the least-squares ratio of the
    two columns. The variance is ``cᵀ P c`` with ``c = e_s + σ_e e_b``.

    Parameters
    ----------
    observations : list of ekf.Observation, ekf.update.EvaluatedObservations or ekf.EpochRows
        The epoch's rows (evaluated at ``x`` when they say so).
    x : ndarray, shape (n,)
    P : ndarray, shape (n, n)
        The prior.
    i_s, i_bias : int
        Columns of ``s`` and of the code-bias state.

    Returns
    -------
    float
        m² (``P_ss`` where no row carries the state).
    """
    if hasattr(observations, "observations"):             # ekf.EpochRows
        observations = observations.observations
    evaluated = getattr(observations, "innov", None) is not None \
        and observations.evaluated_at(x)
    num = den = 0.0
    start = 0
    for obs in observations:
        m = obs.z.size
        if obs.model.name in _POSITION_MODELS:
            H = observations.H[start:start + m] if evaluated else \
                obs.model.evaluate(x, obs.p)[1]
            num += float(H[:, i_s] @ H[:, i_bias])
            den += float(H[:, i_s] @ H[:, i_s])
        start += m
    c = np.zeros(np.size(x))
    c[i_s], c[i_bias] = 1.0, (num / den if den > 0.0 else 0.0)
    return float(c @ P @ c)
