"""The fixes' Gauss–Markov bias in the network navigator's evidence
(`railnav.navigation.fix_bias`): the sequence likelihood against the closed-form joint
Gaussian, the merge against hand-computed moments, and a real log degraded to
single-point quality against its carrier-fixed truth."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from railnav.errors import ConfigError
from railnav.navigation.fix_bias import FixBias, cross_row_evidence, merged
from railnav.navigation.network_config import NetworkNavConfig

REPO = Path(__file__).resolve().parents[3]
LOG = REPO / "data" / "fixes" / "brussels" / "log_28554_L36-A_to_L36C-A.csv"


def test_the_sequence_likelihood_is_the_joint_gaussian_of_white_plus_gauss_markov():
    """Summed over epochs, the per-epoch log-densities equal the log-density of the whole
    residual sequence under its joint covariance ``R_k δ_kl + σ_b² (c_k·c_l)
    e^{−|t_k − t_l|/τ}`` (each horizontal axis its own Gauss–Markov process; the cross
    direction turning), computed by SciPy from that matrix: a second method."""
    rng = np.random.default_rng(7)
    n, sigma_b, tau = 9, 2.0, 60.0
    t = np.cumsum(rng.uniform(0.2, 30.0, n))
    heading = rng.uniform(0.0, 2.0 * math.pi, n)
    c = np.column_stack([np.cos(heading), -np.sin(heading)])
    R = rng.uniform(1.0, 6.0, n)
    nu = rng.normal(0.0, 3.0, n)
    cov = np.diag(R) + sigma_b ** 2 * (c @ c.T) * np.exp(-np.abs(t[:, None] - t) / tau)
    total, bias = 0.0, None
    for k in range(n):
        ll, (bias,) = cross_row_evidence([bias], c[k:k + 1], nu[k:k + 1], R[k:k + 1],
                                         float(t[k]), sigma_m=sigma_b, tau_s=tau)
        total += float(ll[0])
    assert total == pytest.approx(multivariate_normal(np.zeros(n), cov).logpdf(nu),
                                  rel=0, abs=1e-9)


def test_without_correlation_time_every_fix_is_white_noise_of_both_variances():
    """τ = 0: the bias is new at every fix, so each row is ``N(0, R + σ_b²)`` alone."""
    bias = FixBias(np.array([5.0, -3.0]), 0.1 * np.eye(2), 0.0)
    ll, _ = cross_row_evidence([bias], np.array([[0.6, 0.8]]), np.array([1.5]),
                               np.array([4.0]), 1.0, sigma_m=2.0, tau_s=0.0)
    assert ll[0] == pytest.approx(-0.5 * (1.5 ** 2 / 8.0 + math.log(8.0)
                                          + math.log(2.0 * math.pi)), abs=1e-12)


def test_merged_bias_has_the_mixture_moments():
    """Weights 1/4, 3/4, means (0, 0) and (2, 0), covariances I: mean (1.5, 0), covariance
    I + diag(¼·¾·2², 0) (by hand); a hypothesis without a bias is left out."""
    a = FixBias(np.zeros(2), np.eye(2), 3.0)
    b = FixBias(np.array([2.0, 0.0]), np.eye(2), 3.0)
    out = merged(np.array([0.2, 0.6, 0.2]), [a, b, None])
    np.testing.assert_allclose(out.mean_m, [1.5, 0.0], atol=1e-12)
    np.testing.assert_allclose(out.cov_m2, np.eye(2) + np.diag([0.75, 0.0]), atol=1e-12)
    assert merged(np.array([1.0]), [None]) is None


def test_config_checks_the_bias_sigma():
    with pytest.raises(ConfigError, match="fix_bias_sigma_m"):
        NetworkNavConfig(fix_bias_sigma_m=-1.0)


@pytest.fixture(scope="module")
def degraded(tmp_path_factory):
    """log_28554 degraded to single-point quality (seed 2), its truth from the original's
    carrier-fixed rows, and the network."""
    import pandas as pd

    from railnav.evaluation.netelement_truth import netelement_truth
    from railnav.simulation.fix_degrade import degrade_log
    from trackmodel.network_io import read_network
    network = read_network(REPO / "data" / "networks" / "brussels_airport")
    raw = pd.read_csv(LOG)
    truth = netelement_truth(network, np.radians(raw["latitude"].to_numpy()),
                             np.radians(raw["longitude"].to_numpy()))
    truth[raw["position_type"].to_numpy() != "NARROW_INT3"] = None
    path = tmp_path_factory.mktemp("spp") / "log_28554_spp2.csv"
    degrade_log(LOG, path, seed=2)
    return network, path, truth


def _scores(network, path, truth, nav):
    from railnav.evaluation.netelement_truth import netelement_scores
    from railnav.jobs.network import run_files_network
    run = run_files_network(network, fixes_path=path, nav=nav)
    tab = run.outcome.data.fixes.table
    t = tab["gps_time_s"].to_numpy() - run.outcome.data.start_gps_time_s
    cyc = run.network_result.cycles
    return netelement_scores(cyc["time_s"], cyc["netelement"],
                             cyc["netelement_probability"], t, truth)


def test_real_log_degraded_is_right_where_tplib_is(degraded):
    """log_28554 degraded (2 m white + 2 m Gauss–Markov, τ 60 s, seed 2), that model
    declared: the netelement is right at all 195 epochs with a carrier-fixed truth, as
    tp-lib (an offline HMM over all the fixes) is on the same file. (Measured with only
    the correlation time declared: 193; the two epochs after the switch at 62 s a coin
    toss, P 0.499 against 0.497.)"""
    network, path, truth = degraded
    sc = _scores(network, path, truth, NetworkNavConfig(evidence_correlation_s=60.0,
                                                        fix_bias_sigma_m=2.0))
    assert sc["epochs"] == 195 and sc["right"] == 195
    assert sc["confident"] > 150 and sc["confident_right"] == sc["confident"]


def test_the_bias_model_needs_the_stacked_fix_only_stepper(degraded):
    network, path, truth = degraded
    with pytest.raises(ConfigError, match="fix_bias_sigma_m"):
        _scores(network, path, truth, NetworkNavConfig(fix_bias_sigma_m=2.0, stacked=False))
