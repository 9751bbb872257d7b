"""Multiple-model banks (Herasimov et al. 2018, SEEDS.md §3): one filter per hypothesis.

Each hypothesis ``j`` is anything with ``predict(x, P, data) -> (x, P)`` and
``update(x, P, data) -> (x, P, UpdateRecord)`` (:class:`Hypothesis`; a linear one is
made from a :class:`~ekf.linear.LinearModel` by :meth:`Hypothesis.linear`). The record's
``log_likelihood = log N(ν; 0, S)`` drives the model probabilities. One :meth:`ModelBank.step`
is: (re)initialize each hypothesis, predict, update, reweight, and mix:

``mode="static"``
    No switching (the "polygaussian" filter): each hypothesis keeps its own estimate;
    ``μ_j ∝ L_j μ_j``. Exact for a model that is one of the hypotheses all along;
    hypotheses may differ in structure (state sizes may then differ: no mixed estimate).
``mode="gpb1"``
    The "pulsating" filter: after every step the bank is merged to ONE Gaussian (moment
    matching) that starts every hypothesis at the next step; prior probabilities
    ``c = Πᵀ μ`` with the switching matrix ``Π[i, j] = P(model j at k | model i at k−1)``.
``mode="imm"``
    Interacting multiple models (Blom & Bar-Shalom 1988): each hypothesis starts from
    its own mixture ``Σ_i μ_{i|j} x_i`` of the previous estimates.

Log-likelihoods are combined in log space (no underflow on long runs).

The pieces are public for banks driven step by step from outside (e.g. filters that run
their own time loops in lockstep): `switching_update` (the probability recursion),
`imm_starts` (IMM mixing, with an optional ``convert(i, j, x, P)`` for hypotheses whose
states are expressed in coordinates of their own, e.g. a distance along their own path)
and `uniform_switching` (the switching matrix of a continuous-time chain that leaves
each model at one rate, to the others alike).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Literal, Sequence

import numpy as np
import numpy.typing as npt

from ekf.errors import ModelError
from ekf.linear import LinearModel
from ekf.update import UpdateRecord

__all__ = ["Hypothesis", "BankStep", "ModelBank", "merge_gaussians", "merge_gaussians_many",
           "switching_update", "log_predict", "logsumexp", "imm_starts", "imm_mixing",
           "uniform_switching", "Convert"]

Array = npt.NDArray[np.float64]
Mode = Literal["static", "gpb1", "imm"]
#: ``convert(i, j, x_i, P_i) -> (x, P)``: hypothesis i's estimate in hypothesis j's
#: coordinates.
Convert = Callable[[int, int, Array, Array], tuple[Array, Array]]
_TINY = np.finfo(float).tiny


@dataclass(frozen=True)
class Hypothesis:
    """One model of a bank.

    Attributes
    ----------
    predict : callable (x, P, data) -> (x, P)
    update : callable (x, P, data) -> (x, P, UpdateRecord)
    name : str
    """

    predict: Callable[[Array, Array, Any], tuple[Array, Array]]
    update: Callable[[Array, Array, Any], tuple[Array, Array, UpdateRecord]]
    name: str = "model"

    @classmethod
    def linear(cls, model: LinearModel, name: str = "model") -> "Hypothesis":
        """A hypothesis of a linear model; ``data`` of a step is the measurement ``z``."""
        return cls(predict=lambda x, P, z: model.predict(x, P),
                   update=lambda x, P, z: model.update(x, P, z), name=name)


def merge_gaussians(weights: Array, means: Array, covs: Array) -> tuple[Array, Array]:
    """Moment-matched single Gaussian of a mixture.

    Parameters
    ----------
    weights : ndarray, shape (J,)
        Summing to 1.
    means : ndarray, shape (J, n)
    covs : ndarray, shape (J, n, n)

    Returns
    -------
    mean : ndarray, shape (n,)
    cov : ndarray, shape (n, n)
        ``Σ w_j (P_j + (x_j − x)(x_j − x)ᵀ)``.
    """
    mean, cov = merge_gaussians_many(np.asarray(weights, dtype=float)[None],
                                     np.asarray(means, dtype=float)[None],
                                     np.asarray(covs, dtype=float)[None])
    return mean[0], cov[0]


def merge_gaussians_many(weights: Array, means: Array, covs: Array) -> tuple[Array, Array]:
    """`merge_gaussians` of T mixtures of J components each, in one evaluation (NumPy's
    stacked ``matmul`` and ``einsum`` sum each mixture's products as for it alone: the
    same numbers).

    Parameters
    ----------
    weights : ndarray, shape (T, J)
        Each mixture's, summing to 1.
    means : ndarray, shape (T, J, n)
    covs : ndarray, shape (T, J, n, n)

    Returns
    -------
    mean : ndarray, shape (T, n)
    cov : ndarray, shape (T, n, n)
    """
    mean = (weights[:, None, :] @ means)[:, 0, :]
    spread = means - mean[:, None, :]
    cov = np.einsum("tj,tjab->tab", weights, covs) + np.einsum("tj,tja,tjb->tab", weights,
                                                               spread, spread)
    return mean, 0.5 * (cov + np.swapaxes(cov, -1, -2))


def logsumexp(a: npt.ArrayLike, axis: int | None = None) -> Array | float:
    """``log Σ exp(a)`` along `axis` without overflow (−inf entries allowed; all −inf
    gives −inf). Plain NumPy: banks call it every cycle on a few values, where
    `scipy.special.logsumexp`'s argument handling costs ~20 times the arithmetic."""
    a = np.asarray(a, dtype=float)
    top = np.max(a, axis=axis, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.sum(np.exp(a - top), axis=axis, keepdims=True)) + top
    return out.item() if axis is None else np.squeeze(out, axis=axis)


def switching_update(log_mu: Array, log_lik: Array, transition: Array | None = None) -> Array:
    """One step of the model-probability recursion, in log space.

    Parameters
    ----------
    log_mu : ndarray, shape (J,)
        Log probabilities of the previous step (normalized or not).
    log_lik : ndarray, shape (J,)
        Log-likelihood of this step's data under each model (``−inf`` allowed: the model
        is ruled out).
    transition : ndarray, shape (J, J), optional
        ``Π[i, j] = P(model j now | model i before)``; None: no switching.

    Returns
    -------
    ndarray, shape (J,)
        Normalized ``log μ_j ∝ log c_j + log L_j``, ``c = Πᵀ μ``.
    """
    log_mu = np.asarray(log_mu, dtype=float)
    if transition is not None:
        log_mu = log_predict(log_mu, transition)
    out = log_mu + np.asarray(log_lik, dtype=float)
    return out - logsumexp(out)


def log_predict(log_mu: Array, transition: Array) -> Array:
    """``log (Πᵀ μ)`` computed in log space: ``log c_j = logsumexp_i(log Π_ij + log μ_i)``.

    No probability is floored: a model whose log probability is −2000 keeps it (plus what
    the chain moves to it) instead of being lifted to ``log(tiny) ≈ −708``, from where a
    single step's likelihood ratio could revive it.

    Parameters
    ----------
    log_mu : ndarray, shape (J,)
        Log probabilities (−inf allowed), normalized or not.
    transition : ndarray, shape (J, J)
        ``Π[i, j]`` (zeros allowed).

    Returns
    -------
    ndarray, shape (J,)
        Normalized like `log_mu` (the rows of Π sum to 1).
    """
    with np.errstate(divide="ignore"):
        log_t = np.log(np.asarray(transition, dtype=float))
    return logsumexp(np.asarray(log_mu, dtype=float)[:, None] + log_t, axis=0)


def imm_starts(mu: Array, transition: Array, xs: Sequence[Array], Ps: Sequence[Array], *,
               convert: Convert | None = None, min_weight: float = 0.0,
               mixing: tuple[Array, list[list[int]]] | None = None
               ) -> tuple[list[Array], list[Array]]:
    """IMM mixing (Blom & Bar-Shalom 1988): each hypothesis' start of the next step.

    Parameters
    ----------
    mu : ndarray, shape (J,)
        Model probabilities (summing to 1).
    transition : ndarray, shape (J, J)
        Switching matrix (rows sum to 1).
    xs, Ps : sequence of ndarray (n,), (n, n)
        Each hypothesis' estimate in its own coordinates.
    convert : callable, optional
        ``convert(i, j, x_i, P_i)``: hypothesis i's estimate in j's coordinates (default:
        all hypotheses share the coordinates).
    min_weight : float
        Mixing weights ``μ_{i|j}`` (i ≠ j) below this are left out (a weight ``w`` moves
        the start by ``w`` times the difference of the two estimates).
    mixing : (ndarray, list), optional
        `imm_mixing` of these ``mu``, ``transition`` and ``min_weight``, when the caller
        has it already.

    Returns
    -------
    x0, P0 : lists of ndarray (n,), (n, n)
        ``Σ_i μ_{i|j} x_{i→j}`` and its moment-matched covariance, ``μ_{i|j} = Π_ij μ_i / c_j``.
    """
    weights, uses = imm_mixing(mu, transition, min_weight) if mixing is None else mixing
    x0, P0 = list(xs), list(Ps)
    # the estimates each start mixes (converted in the order of the starts), then the
    # starts that mix as many merged together (`merge_gaussians_many`: the same numbers)
    mixed: dict[int, list[tuple[int, Array, list]]] = {}
    for j, use in enumerate(uses):
        if use == [j]:
            continue
        pairs = [(xs[i], Ps[i]) if i == j or convert is None else convert(i, j, xs[i], Ps[i])
                 for i in use]
        mixed.setdefault(len(use), []).append((j, weights[use, j] / weights[use, j].sum(),
                                               pairs))
    for group in mixed.values():
        x, P = merge_gaussians_many(np.array([w for _, w, _ in group]),
                                    np.array([[p[0] for p in pairs] for *_, pairs in group],
                                             dtype=float),
                                    np.array([[p[1] for p in pairs] for *_, pairs in group],
                                             dtype=float))
        for (j, _, _), x_j, P_j in zip(group, x, P):
            x0[j], P0[j] = x_j, P_j
    return x0, P0


def imm_mixing(mu: Array, transition: Array, min_weight: float = 0.0
               ) -> tuple[Array, list[list[int]]]:
    """The mixing weights of `imm_starts` and what each start mixes.

    Returns
    -------
    weights : ndarray, shape (J, J)
        ``μ_{i|j} = Π_ij μ_i / c_j``, ``c = Πᵀ μ``.
    uses : list of list of int
        For each j, the i (in order) that its start mixes: j itself and those with
        ``μ_{i|j} > min_weight``. A caller that converts states in batches
        (``convert(i, j, …)`` for every ``i != j`` of ``uses[j]``, unless ``uses[j] == [j]``)
        knows the pairs from it beforehand.
    """
    mu = np.asarray(mu, dtype=float)
    c = transition.T @ mu
    weights = transition * mu[:, None] / np.maximum(c, _TINY)[None, :]
    mixed = weights > min_weight
    mixed[np.arange(mu.size), np.arange(mu.size)] = True     # j itself, whatever its weight
    uses = [[i for i, yes in enumerate(column) if yes] for column in mixed.T.tolist()]
    return weights, uses


def uniform_switching(n_models: int, rate_per_s: float, dt_s: float) -> Array:
    """Switching matrix over ``dt_s`` of a chain that leaves each model at ``rate_per_s``.

    The continuous-time chain has generator ``Λ_ij = rate/(J − 1)`` (i ≠ j), ``Λ_ii = −rate``:
    ``Π(Δt) = exp(Λ Δt) = 11ᵀ/J + (I − 11ᵀ/J) e^{−J rate Δt/(J − 1)}``, whose stationary
    probabilities are uniform.

    Parameters
    ----------
    n_models : int
        ``J`` >= 1.
    rate_per_s : float
        Rate of leaving a model, 1/s, >= 0.
    dt_s : float
        Interval, s, >= 0.

    Returns
    -------
    ndarray, shape (J, J)
    """
    if n_models < 1 or rate_per_s < 0.0 or dt_s < 0.0:
        raise ModelError(f"uniform_switching needs J >= 1, rate >= 0 and dt >= 0; got "
                         f"{n_models}, {rate_per_s}, {dt_s}")
    if n_models == 1:
        return np.ones((1, 1))
    J = n_models
    decay = np.exp(-J * rate_per_s * dt_s / (J - 1))
    return np.full((J, J), 1.0 / J) + (np.eye(J) - np.full((J, J), 1.0 / J)) * decay


@dataclass(frozen=True)
class BankStep:
    """State of a bank after one step.

    Attributes
    ----------
    probabilities : ndarray, shape (J,)
        Posterior model probabilities ``μ_j``.
    log_likelihoods : ndarray, shape (J,)
        ``log N(ν_j; 0, S_j)`` of this step's update.
    x : ndarray, shape (n,) or None
        Mixed estimate (None for a static bank of different state sizes).
    P : ndarray, shape (n, n) or None
    """

    probabilities: Array
    log_likelihoods: Array
    x: Array | None
    P: Array | None


class ModelBank:
    """A bank of filters with model probabilities.

    Parameters
    ----------
    hypotheses : sequence of Hypothesis
    x0 : sequence of ndarray (n_j,)
        Initial estimate of each hypothesis (equal for gpb1/imm).
    P0 : sequence of ndarray (n_j, n_j)
    prior : ndarray, shape (J,), optional
        Initial probabilities (default uniform, ``1/J``).
    mode : {"static", "gpb1", "imm"}
    transition : ndarray, shape (J, J), optional
        Switching matrix (rows sum to 1); needed for gpb1/imm.
    """

    def __init__(self, hypotheses: Sequence[Hypothesis], x0: Sequence[Array],
                 P0: Sequence[Array], *, prior: Array | None = None, mode: Mode = "static",
                 transition: Array | None = None) -> None:
        J = len(hypotheses)
        if J == 0 or len(x0) != J or len(P0) != J:
            raise ModelError("a bank needs one x0 and one P0 per hypothesis (at least one)")
        self.hypotheses = list(hypotheses)
        self.x = [np.asarray(x, dtype=float) for x in x0]
        self.P = [np.asarray(P, dtype=float) for P in P0]
        prior = np.full(J, 1.0 / J) if prior is None else np.asarray(prior, dtype=float)
        if prior.shape != (J,) or np.any(prior < 0) or not np.isclose(prior.sum(), 1.0):
            raise ModelError("prior must be J probabilities summing to 1")
        with np.errstate(divide="ignore"):
            self.log_mu = np.log(prior)             # a zero prior stays impossible
        if mode not in ("static", "gpb1", "imm"):
            raise ModelError(f"unknown bank mode {mode!r}")
        if mode != "static":
            if transition is None:
                raise ModelError(f"mode {mode!r} needs a transition matrix")
            transition = np.asarray(transition, dtype=float)
            if transition.shape != (J, J) or not np.allclose(transition.sum(axis=1), 1.0):
                raise ModelError("transition must be (J, J) with rows summing to 1")
            if len({x.shape for x in self.x}) != 1:
                raise ModelError(f"mode {mode!r} needs hypotheses of one state size")
        self.mode, self.transition = mode, transition

    @property
    def probabilities(self) -> Array:
        """Current model probabilities ``μ``, shape (J,)."""
        return np.exp(self.log_mu - logsumexp(self.log_mu))

    def _starts(self) -> tuple[list[Array], list[Array]]:
        """Initial conditions of this step."""
        mu = self.probabilities
        if self.mode == "static":
            return self.x, self.P
        if self.mode == "gpb1":
            x, P = merge_gaussians(mu, np.array(self.x), np.array(self.P))
            return [x] * len(mu), [P] * len(mu)
        return imm_starts(mu, self.transition, self.x, self.P)

    def step(self, data: Any) -> BankStep:
        """Predict and update every hypothesis with this step's ``data``; reweight, mix.

        Parameters
        ----------
        data : any
            Passed to every hypothesis' ``predict`` and ``update`` (e.g. ``z``).
        """
        xs, Ps = self._starts()
        log_lik = np.zeros(len(self.hypotheses))
        for j, hyp in enumerate(self.hypotheses):
            x, P = hyp.predict(xs[j], Ps[j], data)
            self.x[j], self.P[j], record = hyp.update(x, P, data)
            log_lik[j] = record.log_likelihood
        self.log_mu = switching_update(self.log_mu, log_lik,
                                       None if self.mode == "static" else self.transition)
        mu = self.probabilities
        x_mix = P_mix = None
        if len({x.shape for x in self.x}) == 1:
            x_mix, P_mix = merge_gaussians(mu, np.array(self.x), np.array(self.P))
        return BankStep(mu, log_lik, x_mix, P_mix)
