r"""One cycle of every hypothesis's filter: propagate to the cycle's end, update there.

`EngineStepper` drives each hypothesis's own filter object (any kind that screens its
rows: `railnav.filters.protocol.FilterKind.banks`, or any kind with fixes) through the
EKF engine (`ekf.CdFilter`), over the same samples for all: from the previous cycle's end
``t[a]`` to this one's ``t[b]``, then the epoch's discrete update at ``t[b]`` when there is
one. The engine holds no hypothesis's state: it is reset to the hypothesis's posterior at
``t[a]`` (one engine per state layout serves all), the filter object computes the inputs
of the samples ``t[a..b]`` from that posterior (`Filter.inputs`), the engine propagates
(`ekf.CdFilter.propagate`) and updates with the epoch's rows built at the prior there
(`Filter.observations`, which screens them: `railnav.filters.fault_detection`), adding an
`ekf.EpochRows` jump covariance first as `ekf.CdFilter` does.

**Kinked joints.** A map's netelements may meet at a kink (a switch digitized as a corner:
5–11° in the Brussels network) where the vehicle runs a curve; the accelerometer
pseudo-observation of the inertial filters would take the curve's lateral acceleration for
an error of the state. Within `KINK_WINDOW_M` (plus 3σ_s) of a joint of its track that
is not tangent-continuous and closed (its kink, or the S-curve that closes its gap,
`railnav.navigation.net_tracks.OrientedTracks.joints`, above
`trackmodel.network_lines.EXACT_KINK_RAD`: where a route line puts a transition), a
hypothesis's pseudo-observation noise density gets the curve a train would run there,
``(v²θ/w)² · w/|v|`` (θ the kink, ``w`` the window): the filter then leans on its IMU
through the joint. Small kinks too (until 2026-12-07 only those above
`trackmodel.network.CONTINUOUS_KINK_RAD`, 0.5°, had it): a corner of 0.28° is still a curve
the map does not carry, and on an element whose curvature changes along it (the reverse
clothoid of a crossover, Brussels 88_L_2016: ``v² dκ/ds`` = 1.6e-3 m/s² per metre at
20 m/s) the pseudo-observation took the 0.02-0.09 m/s² of the route line's transition
there for an error of ``s``: 8 m behind one second past the joint, 100-254 m off at the
end of `benchmarks/bench_network_routes.py`'s trips on 88_L_5900 > 88_L_2016 > 88_L_16908
with σ_s 0.3-0.7 m (its element right by luck until the spawn test of GNSS runs saw it
lost and spawned). The allowance goes as θ², so a 0.02° joint gets 1/200 of a 0.28° one's.

**Continuous evidence on a common covariance** (`common_continuous_log_likelihoods`). Each
step's pseudo-observation innovation ``ν_j`` of hypothesis j is scored against one
covariance for all: at each step, the innovation covariance ``S`` of the hypothesis with
the largest ``det S``. A hypothesis whose own ``S`` is wide — near a kinked joint (above),
or with a curvature change within its σ_s, where the geometry noise of
`railnav.filters.geometry_noise` stands in for "on the straight or already in the curve" —
then pays nothing for that width (its own ``log det S`` would penalize it while the vehicle
may well be where its mean says), and the innovations decide: small for the hypothesis
whose geometry the vehicle follows, large (0.8 m/s² in a 500-m curve at 20 m/s) for the
others.

What the weights need comes back per hypothesis (`CycleOutcome`): the epoch's screen
(innovations at the prior and their covariance, for the common evidence of
`railnav.navigation.bank.common_log_likelihoods`) and the continuous measurement's
innovations and covariances of every step (`ekf.propagate.StepOutputs`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ekf.packing import unpack_sym
from ekf.series import InputSeries, prior_and_rows
from ekf.stacked import propagate_members, update_members
from ekf.step import window_median_at
from railnav.filters.epochs_together import observations_together
from railnav.navigation.loop import filter_engine
from trackmodel.network_lines import EXACT_KINK_RAD, TRANSITION_MAX_M

__all__ = ["EngineStepper", "CycleOutcome", "common_continuous_log_likelihoods",
           "KINK_WINDOW_M", "joint_allowance"]

Array = npt.NDArray[np.float64]

#: The per-step outputs of the engine the weights use (`CycleOutcome.innov_c`, ``S_c``).
CONTINUOUS_OUTPUTS = ("innov", "S")

#: Half-width of the stretch around a kinked joint where the map's geometry is not
#: trusted by the pseudo-observation, m: the longest transition a route line puts after
#: a joint (`trackmodel.network_lines.TRANSITION_MAX_M`, a 1:9 turnout's curve).
KINK_WINDOW_M = TRANSITION_MAX_M


@dataclass(frozen=True, eq=False)
class CycleOutcome:
    """What one cycle gave each hypothesis (in the order they were stepped).

    Attributes
    ----------
    screens : list of EpochScreen or None
        Each filter's screened epoch (None when the cycle had no epoch).
    innov_c : list of ndarray (N, n_c) or None
        Each filter's continuous-measurement innovations of the cycle's N steps (None:
        no continuous measurement, or no step).
    S_c : list of ndarray (N, n_c(n_c+1)/2) or None
        Their covariances, packed (`ekf.packing`).
    steps : int
        Filter steps made (summed over the hypotheses).
    continuous : bool
        The filters have a continuous measurement (the inertial ones).
    evidence : ndarray, shape (K,), optional
        The epoch's evidence when the stepper computed it on the common basis itself
        (`railnav.navigation.stacked_fixes`); None: from `screens`.
    evidence_rows : int
        Rows of that evidence.
    points : (ndarray (K, 3), ndarray (K, 3)), optional
        ECEF position and unit tangent of each hypothesis's point, when the stepper has
        them.
    evidence_whole : ndarray, shape (K,), optional
        Evidence that counts whole whatever the epoch's share (the fix row whose
        correlated error the stepper models, `railnav.navigation.fix_bias`).
    """

    screens: list | None
    innov_c: list | None
    S_c: list | None
    steps: int
    continuous: bool = False
    evidence: Array | None = None
    evidence_rows: int = 0
    points: tuple | None = None
    evidence_whole: Array | None = None


def common_continuous_log_likelihoods(innov: list, S: list) -> Array:
    """``−½ Σ_k ν_jkᵀ S̄_k⁻¹ ν_jk`` of each hypothesis j, ``S̄_k`` the innovation covariance
    of step k with the largest determinant over the hypotheses (module docstring; the
    terms common to all are left out).

    Parameters
    ----------
    innov : list of ndarray, shape (N, n_c)
    S : list of ndarray, shape (N, n_c(n_c+1)/2)
        Their covariances, packed (`ekf.packing`).

    Returns
    -------
    ndarray, shape (K,)
    """
    if len(innov) == 1:       # one hypothesis: its own covariance is the widest
        nu, common = innov[0][None], unpack_sym(S[0])        # (1, N, c), (N, c, c)
    else:
        nu, cov = np.stack(innov), unpack_sym(np.stack(S))   # (K, N, c), (K, N, c, c)
        widest = np.argmax(np.linalg.det(cov), axis=0)        # (N,)
        common = cov[widest, np.arange(cov.shape[1])]         # (N, c, c)
    white = np.linalg.solve(common[None], nu[..., None])[..., 0]
    return -0.5 * np.einsum("knc,knc->k", nu, white)


def joint_allowance(h, tracks, t: Array) -> Array | None:
    """Extra pseudo-observation noise density at samples ``t`` near a kinked joint of the
    hypothesis's track (module docstring), shape (M,); None where there is none."""
    if tracks is None:
        return None
    joints = [(s_j, k) for s_j, k in tracks.joints(h.pieces) if k > EXACT_KINK_RAD]
    if not joints:
        return None
    i_s, i_v = h.index("s"), h.index("v")
    v = float(h.x[i_v])
    s = h.s_m + v * (t - t[0])
    w = KINK_WINDOW_M + 3.0 * float(np.sqrt(max(h.P[i_s, i_s], 0.0)))
    near = np.zeros(t.size)
    for s_j, kink in joints:
        near = np.where(np.abs(s - s_j) < w, np.maximum(near, kink), near)
    if not near.any():
        return None
    speed = max(abs(v), 1.0)
    return (speed ** 2 * near / w) ** 2 * w / speed


class EngineStepper:
    """Steps hypotheses cycle by cycle over a trip's samples (module docstring).

    Parameters
    ----------
    config : railnav.config.NavigatorConfig
    t : ndarray, shape (M,)
        Sample times, s from the trip start.
    u : ndarray, shape (M, n_u)
        Raw inputs of the samples.
    tracks : railnav.navigation.net_tracks.OrientedTracks, optional
        For the joints' kinks.
    stacked : bool
        Propagate the hypotheses of one engine together (`ekf.stacked.propagate_members`:
        the same numbers as the engine's ``reset`` and ``propagate`` one by one, without
        its per-call bookkeeping); False: one by one through the engine.
    """

    def __init__(self, config, t: Array, u: Array, tracks=None, *, stacked: bool = True
                 ) -> None:
        self.config, self.t, self.u, self.tracks = config, t, u, tracks
        self.stacked = stacked
        self._dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
        self._engines: dict[tuple, object] = {}
        #: The latest cycle's ``(a, b, window, u_lin)`` (`_linearization`).
        self._lin: tuple | None = None

    def _linearization(self, engine, a: int, b: int) -> Array | None:
        """``u_lin`` of samples ``a .. b`` for an engine with a Jacobian window
        (`ekf.step.window_median_at` of the trip: the windows
        `railnav.navigation.loop.ChunkLoop` gives a single filter, whatever the cycles;
        once per cycle); None for one without."""
        window = engine.propagator.data.jacobian_window_s
        if window <= 0.0:
            return None
        if self._lin is None or self._lin[:3] != (a, b, window):
            self._lin = (a, b, window, window_median_at(self.t, self.u, a, b + 1, window))
        return self._lin[3]

    def _engine(self, filt):
        key = (type(filt).__name__, filt.layout.names)
        if key not in self._engines:
            self._engines[key] = filter_engine(filt, self.config, sample_interval_s=self._dt)
        return self._engines[key]

    def step(self, hyps, a: int, b: int, epoch: int | None) -> CycleOutcome:
        """Propagate every hypothesis from sample `a` to sample `b` and update it there
        with epoch `epoch` (an index of the trip's epoch schedule; None: no epoch)."""
        if self.stacked and b > a:
            return self._step_stacked(hyps, a, b, epoch)
        screens = [] if epoch is not None else None
        innov, cov = [], []
        t, u = self.t[a:b + 1], self.u[a:b + 1]
        continuous = False
        for h in hyps:
            engine = self._engine(h.filt)
            engine.reset(h.x, h.P)
            out, has = self._propagate(h, engine, t, u, self._linearization(engine, a, b)) \
                if b > a else (None, False)
            continuous = continuous or has
            self._finish(h, engine, epoch, out if has else None, screens, innov, cov)
        full = bool(innov) and len(innov) == len(hyps)
        return CycleOutcome(screens, innov if full else None, cov if full else None,
                            (b - a) * len(hyps), continuous)

    def _step_stacked(self, hyps, a: int, b: int, epoch: int | None) -> CycleOutcome:
        """`step` (``b > a``) with the propagation of each engine's hypotheses together: every
        hypothesis's inputs from its prior, one `ekf.stacked.propagate_members` per
        engine, then the epoch's rows of all (`railnav.filters.epochs_together`), then the
        updates of each engine's hypotheses together (`ekf.stacked.update_members`: each
        one's engine update, to the bit; the order of `step`'s calls per hypothesis: a
        filter object's inputs and rows touch only its own state)."""
        t, u = self.t[a:b + 1], self.u[a:b + 1]
        groups: dict[int, list[int]] = {}
        engines = [self._engine(h.filt) for h in hyps]
        for k, engine in enumerate(engines):
            groups.setdefault(id(engine), []).append(k)
        states: list = [None] * len(hyps)
        has = [False] * len(hyps)
        for members in groups.values():
            series = self._group_series([hyps[k] for k in members], t, u,
                                        self._linearization(engines[members[0]], a, b))
            for k, one in zip(members, series):
                has[k] = one.r_c is not None
            done = propagate_members(engines[members[0]], [(hyps[k].x, hyps[k].P)
                                                           for k in members], series,
                                     keep=CONTINUOUS_OUTPUTS)
            for k, state in zip(members, done):
                states[k] = state
        screens = [] if epoch is not None else None
        posteriors = [(state.x, state.P) for state in states]
        if epoch is not None:
            rows = observations_together([h.filt for h in hyps], epoch, posteriors)
            for members in groups.values():          # each engine's members updated together
                for k, post in zip(members, update_members(
                        engines[members[0]], [posteriors[k] for k in members],
                        [rows[k] for k in members])):
                    posteriors[k] = post
        innov, cov = [], []
        for h, state, has_c, (x, P) in zip(hyps, states, has, posteriors):
            self._collect(h, epoch, state.outputs if has_c else None, screens, innov, cov)
            h.x, h.P = x.copy(), P.copy()
        full = bool(innov) and len(innov) == len(hyps)
        return CycleOutcome(screens, innov if full else None, cov if full else None,
                            (b - a) * len(hyps), any(has))

    def _finish(self, h, engine, epoch: int | None, outputs, screens, innov, cov) -> None:
        """After a hypothesis's propagation: its update with `epoch` (None: none), what
        the weights need (`_collect`), and the engine's state back into the hypothesis."""
        if epoch is not None:
            self._update(h, engine, epoch)
        self._collect(h, epoch, outputs, screens, innov, cov)
        h.x, h.P = engine.x.copy(), engine.P.copy()

    @staticmethod
    def _collect(h, epoch: int | None, outputs, screens, innov, cov) -> None:
        """A stepped hypothesis's continuous innovations (`outputs`, None without) to
        `innov`/`cov` and, after an update with `epoch`, its screen to `screens` (its
        filter's records then forgotten)."""
        if outputs is not None and outputs.innov.shape[0]:
            innov.append(outputs.innov)
            cov.append(outputs.S)
        if epoch is not None:
            screens.append(h.filt.screen.last)
            h.filt.screen.clear_records()

    def _group_series(self, hyps, t: Array, u: Array, u_lin: Array | None = None
                      ) -> list[InputSeries]:
        """`_series` of hypotheses of one engine: their filters' inputs together where the
        filters are of one kind that has ``inputs_together`` (the same numbers as each
        one's ``inputs``: `railnav.filters.constrained.ConstrainedFilter.inputs_together`),
        else one by one."""
        kind = type(hyps[0].filt)
        together = getattr(kind, "inputs_together", None)
        if together is None or len(hyps) < 2 or any(type(h.filt) is not kind for h in hyps):
            return [self._series(h, t, u, u_lin=u_lin) for h in hyps]
        inputs = together([h.filt for h in hyps], t, u, [(h.x, h.P) for h in hyps],
                          float(t[0]))
        return [self._series(h, t, u, one, u_lin) for h, one in zip(hyps, inputs)]

    def _series(self, h, t: Array, u: Array, inputs=None, u_lin: Array | None = None
                ) -> InputSeries:
        """The hypothesis's engine inputs of samples `t` (with any joint allowance;
        `inputs`: its filter's ``inputs`` when already computed; `u_lin`: the samples'
        linearization input)."""
        u_c, p_c, r_c = h.filt.inputs(t, u, h.x, h.P, float(t[0])) if inputs is None \
            else inputs
        extra = None if r_c is None else joint_allowance(h, self.tracks, t)
        if extra is not None:
            r_c = r_c + extra[:, None]
        return InputSeries(t=t, u=u_c, p=p_c, q_c=getattr(h.filt, "step_q_c", h.filt.q_c),
                           r_c=r_c, u_lin=u_lin)

    def _propagate(self, h, engine, t: Array, u: Array, u_lin: Array | None = None):
        """The hypothesis's inputs (with any joint allowance) propagated; the step outputs
        and whether the filter has a continuous measurement."""
        series = self._series(h, t, u, u_lin=u_lin)
        return engine.propagate(series), series.r_c is not None

    @staticmethod
    def _update(h, engine, epoch: int) -> None:
        """The hypothesis's update with `epoch` (its filter's rows at the engine's prior)."""
        engine.P, rows = prior_and_rows(engine.P,
                                        h.filt.observations(epoch, engine.x, engine.P))
        engine.update(rows)
