"""The constrained filter's yaw on a level straight at constant speed, where nothing observes
it (issue 14, part 4: the 10-h trip's yaw overconfidence).

Reference: the closed-form covariance of the yaw and the z-gyro bias there
(`tests.support.straight_yaw`, from the filter's own densities and initial σ), itself
checked against Van Loan's matrix exponential. With the pseudo-observation's Jacobian at
the raw IMU sample (``JACOBIAN_WINDOW_S = 0``) the filter drew yaw information from the
accelerometer noise in ``H``'s yaw column: σ_yaw 4.7 % below the closed form after 400 s
(26 % after 890 s), σ(b_gz) 2.8 % below; this test fails there. At the 0.5-s running
median (centred, shrunk near chunk ends) the information left is that of the median's
noise: σ_yaw 0.4 % and σ(b_gz) 0.25 % below after 400 s (seed 1).
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from railnav.filters.common import JACOBIAN_WINDOW_S
from railnav.filters.constrained import ConstrainedFilter
from railnav.jobs.run import run_simulated
from railnav.simulation.trip import navigator_config_for
from tests.support.straight_yaw import (filter_yaw_densities, straight_scenario,
                                        straight_track, straight_yaw_covariance)

DURATION_S = 400.0
#: The filter may be at most this much more confident than the closed form (its σ this much
#: below): the median's leftover noise in ``H``, and the neglected Earth-rate couplings.
MAX_OVERCONFIDENCE = 0.02
#: ... and at most this much less confident (nothing else adds noise to the yaw there).
MAX_UNDERCONFIDENCE = 0.01


def test_closed_form_equals_van_loan():
    """``δψ̇ = −δb − w_g``, ``δḃ = w_b`` discretized by Van Loan's exponential (a second
    method) over 0–900 s."""
    q_g, q_b, s_psi, s_b = 8.5e-10, 2e-14, 1e-3, 5.4e-6
    A = np.array([[0.0, -1.0], [0.0, 0.0]])
    Qc = np.diag([q_g, q_b])
    P0 = np.diag([s_psi ** 2, s_b ** 2])
    for t in (1.0, 250.0, 900.0):
        M = sla.expm(np.block([[-A, Qc], [np.zeros((2, 2)), A.T]]) * t)
        Phi = M[2:, 2:].T
        Q = Phi @ M[:2, 2:]
        want = Phi @ P0 @ Phi.T + Q
        got = straight_yaw_covariance(t, sigma_yaw0_rad=s_psi, sigma_bias0_radps=s_b,
                                      q_gyro=q_g, q_bias=q_b)
        np.testing.assert_allclose(got, want, rtol=1e-9)


@pytest.fixture(scope="module")
def straight_run():
    track, scenario = straight_track(DURATION_S), straight_scenario(DURATION_S)
    config = navigator_config_for(scenario)
    densities = filter_yaw_densities(ConstrainedFilter(track, config), config)
    estimates = run_simulated(track, scenario, config=config, seed=1).result.estimates
    return estimates, densities


def test_yaw_sigma_on_a_straight_is_the_closed_form(straight_run):
    assert JACOBIAN_WINDOW_S > 0.0
    est, densities = straight_run
    t = est["time_s"].to_numpy()
    # the first row is (within the first update at t = 0) the prior of the closed form
    assert np.radians(est["sigma_yaw_deg"].iloc[0]) == pytest.approx(
        densities["sigma_yaw0_rad"], rel=1e-4)
    P = straight_yaw_covariance(t[-1] - t[0], **densities)
    sigma_yaw = np.radians(est["sigma_yaw_deg"].to_numpy()[-1])
    sigma_bias = est["sigma_gyro_bias_z_radps"].to_numpy()[-1]
    for got, want in ((sigma_yaw, np.sqrt(P[0, 0])), (sigma_bias, np.sqrt(P[1, 1]))):
        assert 1.0 - MAX_OVERCONFIDENCE <= got / want <= 1.0 + MAX_UNDERCONFIDENCE
