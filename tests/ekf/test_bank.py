"""Model banks (ekf/bank.py) against brute-force enumeration of model sequences on a
two-model linear switching system: every sequence gets its own textbook Kalman filter
(explicit inverses) and the exact posterior is the likelihood-weighted mixture."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from ekf.bank import Hypothesis, ModelBank, merge_gaussians, merge_gaussians_many
from ekf.errors import ModelError
from ekf.linear import LinearModel

#: Same Gaussian algebra in another order, a few steps: relative agreement.
RTOL = 1e-10
STEPS = 5
X0, P0 = np.array([0.5, -0.2]), np.diag([2.0, 1.0])
PRIOR = np.array([0.6, 0.4])


def _models():
    """Model 1: a slow, precise sensor; model 2: a fast-turning system, coarse sensor."""
    Phi1 = np.array([[1.0, 0.1], [0.0, 1.0]])
    Phi2 = np.array([[0.9, 0.3], [-0.2, 0.95]])
    H = np.array([[1.0, 0.0]])
    return (LinearModel(Phi1, 0.01 * np.eye(2), H, np.array([[0.1]])),
            LinearModel(Phi2, 0.05 * np.eye(2), H, np.array([[0.8]])))


def _kf_sequence(models, seq, zs, x0, P0):
    """Textbook KF along one model sequence: mean, covariance, log-likelihood."""
    x, P, log_lik = x0.copy(), P0.copy(), 0.0
    for m, z in zip(seq, zs):
        mod = models[m]
        x, P = mod.Phi @ x, mod.Phi @ P @ mod.Phi.T + mod.Q
        S = mod.H @ P @ mod.H.T + mod.R
        nu = z - mod.H @ x
        log_lik += -0.5 * (nu @ np.linalg.inv(S) @ nu + np.log(np.linalg.det(S))
                           + nu.size * np.log(2 * np.pi))
        K = P @ mod.H.T @ np.linalg.inv(S)
        x, P = x + K @ nu, (np.eye(2) - K @ mod.H) @ P
    return x, P, log_lik


def _enumerate(models, zs, transition, x0=X0, P0=P0, prior0=PRIOR):
    """Exact mode probabilities at the last step and the exact mixture mean, with
    ``prior0`` the probabilities of the first step's model."""
    weights, means, last = [], [], []
    for seq in itertools.product(range(2), repeat=len(zs)):
        prior = prior0[seq[0]] * np.prod([transition[a, b] for a, b in zip(seq, seq[1:])])
        x, _, log_lik = _kf_sequence(models, seq, zs, x0, P0)
        weights.append(prior * np.exp(log_lik))
        means.append(x)
        last.append(seq[-1])
    w = np.array(weights) / np.sum(weights)
    probs = np.array([w[np.array(last) == j].sum() for j in range(2)])
    return probs, w @ np.array(means)


def _measurements(rng):
    return [rng.normal(size=1) for _ in range(STEPS)]


def test_static_bank_equals_enumeration_without_switching(rng):
    """With no switching only the two constant sequences have weight: exact."""
    models, zs = _models(), _measurements(rng)
    bank = ModelBank([Hypothesis.linear(m) for m in models], [X0, X0], [P0, P0], prior=PRIOR)
    for z in zs:
        out = bank.step(z)
    probs, mean = _enumerate(models, zs, np.eye(2))
    np.testing.assert_allclose(out.probabilities, probs, rtol=RTOL)
    np.testing.assert_allclose(out.x, mean, rtol=RTOL)


def test_imm_with_identity_switching_is_the_static_bank(rng):
    models, zs = _models(), _measurements(rng)
    hyps = [Hypothesis.linear(m) for m in models]
    imm = ModelBank(hyps, [X0, X0], [P0, P0], prior=PRIOR, mode="imm", transition=np.eye(2))
    static = ModelBank(hyps, [X0, X0], [P0, P0], prior=PRIOR)
    for z in zs:
        a, b = imm.step(z), static.step(z)
    np.testing.assert_allclose(a.probabilities, b.probabilities, rtol=RTOL)
    np.testing.assert_allclose(a.x, b.x, rtol=RTOL)


def test_gpb1_is_exact_for_one_step_from_its_merged_gaussian(rng):
    """GPB1 at each step = exact enumeration of one switching step started from the
    previous merged Gaussian (and over a horizon of one step it is the exact filter)."""
    models, zs = _models(), _measurements(rng)
    transition = np.array([[0.9, 0.1], [0.3, 0.7]])
    bank = ModelBank([Hypothesis.linear(m) for m in models], [X0, X0], [P0, P0],
                     prior=PRIOR, mode="gpb1", transition=transition)
    mu, x, P = PRIOR, X0, P0
    for z in zs:
        out = bank.step(z)
        # one exact switching step from the merge: first-step probabilities Πᵀ μ
        probs, mean = _enumerate(models, [z], transition, x, P, transition.T @ mu)
        np.testing.assert_allclose(out.probabilities, probs, rtol=RTOL)
        np.testing.assert_allclose(out.x, mean, rtol=RTOL)
        mu, x, P = out.probabilities, out.x, out.P


def test_imm_equals_gpb1_when_switching_forgets_the_past(rng):
    """Identical rows of Π (switching independent of the current model, the fault case
    of Herasimov 2018): every IMM mixture is the GPB1 merge."""
    models, zs = _models(), _measurements(rng)
    transition = np.array([[0.8, 0.2], [0.8, 0.2]])
    hyps = [Hypothesis.linear(m) for m in models]
    kw = dict(prior=PRIOR, transition=transition)
    imm = ModelBank(hyps, [X0, X0], [P0, P0], mode="imm", **kw)
    gpb = ModelBank(hyps, [X0, X0], [P0, P0], mode="gpb1", **kw)
    for z in zs:
        a, b = imm.step(z), gpb.step(z)
        np.testing.assert_allclose(a.probabilities, b.probabilities, rtol=RTOL)
        np.testing.assert_allclose(a.P, b.P, rtol=RTOL)


def test_merge_matches_sample_moments(rng):
    """Reference: mean and covariance of 200 000 draws from the mixture, within 5
    standard errors (estimated from the draws)."""
    w = np.array([0.3, 0.7])
    means = np.array([[0.0, 1.0], [2.0, -1.0]])
    covs = np.array([np.eye(2), np.diag([0.5, 2.0])])
    mean, cov = merge_gaussians(w, means, covs)
    pick = rng.random(200_000) < w[0]
    draws = np.where(pick[:, None], rng.multivariate_normal(means[0], covs[0], pick.size),
                     rng.multivariate_normal(means[1], covs[1], pick.size))
    centred = draws - draws.mean(axis=0)
    products = centred[:, :, None] * centred[:, None, :]
    tol_mean = 5 * draws.std(axis=0) / np.sqrt(pick.size)
    tol_cov = 5 * products.std(axis=0) / np.sqrt(pick.size)  # standard errors, 5σ
    assert np.all(np.abs(draws.mean(axis=0) - mean) <= tol_mean)
    assert np.all(np.abs(np.cov(draws.T) - cov) <= tol_cov)


def test_bank_validates_its_configuration():
    models = _models()
    hyps = [Hypothesis.linear(m) for m in models]
    with pytest.raises(ModelError):
        ModelBank(hyps, [X0, X0], [P0, P0], mode="gpb1")
    with pytest.raises(ModelError):
        ModelBank(hyps, [X0, X0], [P0, P0], prior=np.array([0.5, 0.6]))


def test_uniform_switching_is_the_matrix_exponential_of_its_generator():
    """Reference: `scipy.linalg.expm` of the generator (rate/(J−1) off the diagonal)."""
    from scipy.linalg import expm

    from ekf.bank import uniform_switching
    for J, rate, dt in ((2, 1e-3, 1.0), (3, 0.05, 7.5), (4, 2.0, 0.3)):
        gen = np.full((J, J), rate / (J - 1))
        np.fill_diagonal(gen, -rate)
        np.testing.assert_allclose(uniform_switching(J, rate, dt), expm(gen * dt), rtol=1e-12)
    np.testing.assert_array_equal(uniform_switching(3, 0.1, 0.0), np.eye(3))
    with pytest.raises(ModelError):
        uniform_switching(2, -1.0, 1.0)


def test_switching_update_equals_enumeration_over_model_sequences(rng):
    """Exact reference: the forward recursion against the sum over all 2^K sequences
    of prior × likelihood, for given per-step likelihoods of each model."""
    from ekf.bank import switching_update
    K = 6
    log_lik = rng.normal(scale=2.0, size=(K, 2))
    transition = np.array([[0.95, 0.05], [0.2, 0.8]])
    log_mu = np.log(PRIOR)
    for k in range(K):
        log_mu = switching_update(log_mu, log_lik[k], transition if k else None)
    weights = np.zeros(2)
    for seq in itertools.product(range(2), repeat=K):
        prior = PRIOR[seq[0]] * np.prod([transition[a, b] for a, b in zip(seq, seq[1:])])
        weights[seq[-1]] += prior * np.exp(sum(log_lik[k, m] for k, m in enumerate(seq)))
    np.testing.assert_allclose(np.exp(log_mu), weights / weights.sum(), rtol=RTOL)


def test_imm_starts_in_own_coordinates_equal_the_shared_ones(rng):
    """Hypothesis j keeps its state shifted by c_j (x_j = x + c_j): mixing through
    ``convert`` must give the shared-coordinate mixture shifted by c_j."""
    from ekf.bank import imm_starts
    J, n = 3, 2
    shift = rng.normal(size=(J, n)) * 10
    xs = [rng.normal(size=n) for _ in range(J)]
    Ps = []
    for _ in range(J):
        A = rng.normal(size=(n, n))
        Ps.append(A @ A.T + np.eye(n))
    mu = np.array([0.7, 0.2, 0.1])
    transition = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.0, 0.3, 0.7]])
    shared = imm_starts(mu, transition, xs, Ps)
    from ekf.bank import imm_mixing
    given = imm_starts(mu, transition, xs, Ps, mixing=imm_mixing(mu, transition))
    for a, b in zip(shared[0] + shared[1], given[0] + given[1]):   # the mixing given
        np.testing.assert_array_equal(a, b)
    # what each start mixes: μ_{i|j} = Π_ij μ_i / c_j above 0.06 (c = [0.65, 0.225, 0.25]:
    # column 0 is 0.969, 0.031, 0), and j itself
    assert imm_mixing(mu, transition, 0.06)[1] == [[0], [0, 1, 2], [0, 1, 2]]
    assert imm_mixing(mu, transition, 0.2)[1] == [[0], [1], [0, 2]]
    own = imm_starts(mu, transition, [x + c for x, c in zip(xs, shift)], Ps,
                     convert=lambda i, j, x, P: (x - shift[i] + shift[j], P))
    for j in range(J):
        np.testing.assert_allclose(own[0][j], shared[0][j] + shift[j], rtol=RTOL)
        np.testing.assert_allclose(own[1][j], shared[1][j], rtol=RTOL)
    # hypothesis 0 receives nothing from 2 (Π[2, 0] = 0); the mixture is its own moments
    c = transition.T @ mu
    w = transition[:, 0] * mu / c[0]
    mean = sum(w[i] * xs[i] for i in range(J))
    np.testing.assert_allclose(shared[0][0], mean, rtol=RTOL)
    # a weight below min_weight leaves the estimate alone
    lone = imm_starts(np.array([1 - 1e-12, 1e-12, 0.0]), np.eye(3) * 0.999 + 0.001 / 3, xs,
                      Ps, min_weight=1e-6)
    np.testing.assert_array_equal(lone[0][0], xs[0])


def test_a_long_dead_model_is_not_floored_and_revived():
    """Issue 13's flaw of the static bank: probabilities were floored at ``tiny``
    (log ≈ −708), so one step whose likelihood ratio exceeded e^708 revived a model the
    data had ruled out by e^2000. In log space the model keeps −2000 + 800 = −1200."""
    from ekf.bank import log_predict, switching_update
    log_mu = np.array([0.0, -2000.0])
    for transition in (None, np.eye(2)):
        out = switching_update(log_mu, np.array([-800.0, 0.0]), transition)
        np.testing.assert_allclose(out, [0.0, -1200.0], atol=1e-9)
    # what a chain moves there is kept exactly: log(ε) for a model that was −inf
    eps = 1e-7
    moved = log_predict(np.array([0.0, -np.inf]), np.array([[1 - eps, eps], [0.0, 1.0]]))
    np.testing.assert_allclose(moved, [np.log1p(-eps), np.log(eps)], rtol=1e-8)  # 1 - ε rounds


def test_logsumexp_equals_scipy(rng):
    from scipy.special import logsumexp as reference

    from ekf.bank import logsumexp
    a = rng.normal(scale=300.0, size=(5, 4))
    a[1, 2] = -np.inf
    for axis in (None, 0, 1):
        np.testing.assert_allclose(logsumexp(a, axis=axis), reference(a, axis=axis),
                                   rtol=1e-14)
    assert logsumexp(np.full(3, -np.inf)) == -np.inf


def test_mixtures_merged_together_equal_each_merged_alone(rng):
    """`merge_gaussians_many` of T mixtures (stacked matmul and einsum) against each
    mixture's moments written for it alone (``w @ x``, ``Σ w P + Σ w d dᵀ`` by 2-D
    einsum): the same numbers to the bit, what the bank's conversions rely on
    (`railnav.navigation.network_weights.mix_states`), over state sizes and mixture
    lengths."""
    for n, J, T in [(1, 2, 3), (2, 1, 1), (7, 3, 5), (10, 4, 2), (16, 9, 4)]:
        w = rng.random((T, J))
        w /= w.sum(axis=1, keepdims=True)
        means = rng.normal(size=(T, J, n)) * np.logspace(0, 5, n)   # states of many scales
        A = rng.normal(size=(T, J, n, n))
        covs = A @ np.swapaxes(A, -1, -2)
        mean, cov = merge_gaussians_many(w, means, covs)
        for t in range(T):
            m = w[t] @ means[t]
            d = means[t] - m
            c = np.einsum("j,jab->ab", w[t], covs[t]) + np.einsum("j,ja,jb->ab", w[t], d, d)
            np.testing.assert_array_equal(mean[t], m)
            np.testing.assert_array_equal(cov[t], 0.5 * (c + c.T))


def test_mixing_uses_are_each_start_and_its_weights_above_the_floor(rng):
    """`imm_mixing`'s ``uses`` against its definition written out: for each start j, j
    itself and every i with ``μ_{i|j} > min_weight``, in order; weights of exactly 0 (a
    hypothesis of probability 0) left out."""
    from ekf.bank import imm_mixing
    for J, floor in ((1, 0.0), (4, 0.0), (6, 1e-3), (8, 0.2)):
        mu = rng.dirichlet(np.ones(J))
        T = rng.uniform(0.0, 1.0, (J, J)) * (rng.uniform(size=(J, J)) > 0.4)
        T[np.arange(J), np.arange(J)] += 0.5
        T = T / T.sum(axis=1, keepdims=True)
        if J > 1:
            mu[0] = 0.0                                  # weights of exactly 0
        weights, uses = imm_mixing(mu, T, floor)
        ref = [[i for i in range(J) if i == j or weights[i, j] > floor] for j in range(J)]
        assert uses == ref
