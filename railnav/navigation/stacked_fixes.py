r"""The network navigator's cycle for fix-only runs, all hypotheses at once (NumPy).

A fix-only run (the GNSS-only filter on position fixes, state ``[s, v]``, no IMU, no
pseudoranges) does little per hypothesis and epoch; driven filter object by filter
object (`railnav.navigation.hypothesis_step.EngineStepper`) the Python around it costs
~1 ms per hypothesis and epoch, most of it looking up the track. `StackedFixStepper`
does the same arithmetic for the K hypotheses as arrays:

* **Track.** Each oriented element is sampled once on nodes every
  `railnav.navigation.fix_grid.GRID_STEP_M` (`railnav.navigation.fix_grid.FixGrid`, all
  elements in one table); a hypothesis's point is its nearest node
  expanded to second order in ``δ = s − s_node`` (position ``r + C(u δ + ½ u' δ²)``,
  tangent ``u + u' δ``, azimuth and elevation to first order): |δ| ≤ 0.25 m leaves
  ~``κ' δ³`` (sub-µm), what `railnav.filters.track_grid` argues for the inertial filters.
* **Propagation** over the cycle's samples, step by step as the engine does it
  (`ekf.step`: ``Φ = [[1, Δt], [0, 1]]``, ``Q = σ_a² Δt Ḡ Ḡᵀ``, ``Ḡ = (I + Φ)/2 · [0, 1]ᵀ``).
* **Fix rows** at the prior, those of `railnav.filters.fix_rows` (along, cross, up with
  a height, speed with a velocity; their ``z``, ``R`` and ``∂h/∂[s, v]`` at the prior's
  point: the cross and up rows do not depend on ``s`` there), screened as
  `railnav.filters.fault_detection.RowScreen` screens a fix (a row whose normalized
  innovation exceeds the screen's threshold fails, and a fix is used whole or not at
  all), then the engine's row gate and the Kalman update (Joseph form) of the rows kept.
* **Evidence** on the common basis of `railnav.navigation.bank.common_log_likelihoods`:
  every fix row is seen by every hypothesis, so the rows count for all when some
  hypothesis used the fix, and for none when all refused it. With the fixes' bias
  modelled (`NetworkNavConfig.fix_bias_sigma_m`), the cross-track row's term is that of
  `railnav.navigation.fix_bias` instead, returned apart (it counts whole).

Equal to the per-filter path to rounding and the grid's expansion
(``tests/railnav/navigation/test_stacked_fixes.py``).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ekf.gating import chi2_threshold
from ekf.outliers import fault_probability
from ekf.update import LOG_2PI
from railnav.filters.fault_detection import EpochScreen
from railnav.filters.fix_rows import FIX_SV_PREFIX
from railnav.filters.track_frame import track_axes_many_n
from railnav.navigation.fix_bias import with_fix_bias
from railnav.navigation.fix_grid import MAX_KEY_SETS, FixGrid
from railnav.navigation.hypothesis_step import CycleOutcome
from trackmodel.earth import geodetic_to_ecef

__all__ = ["StackedFixStepper", "stackable"]

Array = npt.NDArray[np.float64]


def stackable(config, trip) -> bool:
    """Whether a run is fix-only (`StackedFixStepper` can step it)."""
    return config.filter == "gnss-only" and trip.gnss is None and trip.fixes is not None


def _axes(pt: dict, up: bool = True) -> dict[str, Array]:
    """ENU unit vectors of the track frame at the points (`railnav.filters.fix_rows`;
    `railnav.filters.track_frame.track_axes_many_n`); without ``"up"`` unless `up`."""
    return {"along": pt["u"], **track_axes_many_n(pt["A"], pt["E"] if up else None)}


def _dot(a: Array, b: Array) -> Array:
    return np.einsum("ki,ki->k", a, b)


class StackedScreens:
    """The epoch's screened fix rows of every hypothesis, as `EpochScreen` on demand (for
    ``innovations.csv`` of the most probable one)."""

    def __init__(self, keys, nu: Array, S: Array | None, used: Array, config, *,
                 variances: Array | None = None) -> None:
        self.keys, self.nu, self.used, self.config = keys, nu, used, config
        self._S, self._var = S, variances

    @property
    def S(self) -> Array:
        """Innovation covariances (K, m, m) (from the diagonal `variances` when given so:
        built when first read)."""
        if self._S is None:
            var = self._var
            self._S = np.zeros(var.shape + var.shape[1:])
            self._S[:, np.arange(var.shape[1]), np.arange(var.shape[1])] = var
        return self._S

    @property
    def variances(self) -> Array:
        """The rows' innovation variances (K, m)."""
        return self._var if self._var is not None else np.diagonal(self._S, axis1=1, axis2=2)

    def __len__(self) -> int:
        return self.nu.shape[0]

    def __getitem__(self, k: int) -> EpochScreen:
        var = np.diagonal(self.S[k])
        cfg = self.config
        prob = np.full(var.size, np.nan) if cfg is None else fault_probability(
            self.nu[k] ** 2 / var, prior=cfg.fault_prior, scale=cfg.fault_scale)
        status = np.where(self.used[k], "used", "rejected").astype(object)
        return EpochScreen(self.keys, self.nu[k], self.S[k], status, prob, float("nan"))


class StackedFixStepper:
    """Steps fix-only hypotheses cycle by cycle, all at once (module docstring).

    Parameters
    ----------
    config : railnav.config.NavigatorConfig
    trip : railnav.navigation.navigator.TripSamples
        With ``fixes`` and its ``schedule``, no GNSS observations.
    tracks : railnav.navigation.net_tracks.OrientedTracks
    t : ndarray, shape (M,)
        Sample times, s from the trip start.
    fix_bias_sigma_m, fix_bias_tau_s : float
        σ_b (m; 0: none) and τ (s) of the fixes' bias (`railnav.navigation.fix_bias`).
    """

    def __init__(self, config, trip, tracks, t: Array, *, fix_bias_sigma_m: float = 0.0,
                 fix_bias_tau_s: float = 0.0) -> None:
        self.config, self.t = config, t
        self.bias_sigma_m, self.bias_tau_s = float(fix_bias_sigma_m), float(fix_bias_tau_s)
        self.fixes, self.schedule = trip.fixes, trip.schedule
        self.grid = FixGrid(tracks)
        self.q = float(config.along_accel_sigma_mps2) ** 2
        fd = config.fault_detection
        self.screen_nis = None if fd is None else float(fd.nis_threshold)
        self.gate_nis = None if config.gate_probability is None else \
            float(chi2_threshold(config.gate_probability, 1))
        fx = self.fixes     # r(lat, lon, h) = r(lat, lon, 0) + h n(lat, lon): exact
        zero = np.zeros(len(fx))
        self._r0 = geodetic_to_ecef(fx.lat, fx.lon, zero)
        self._normal = geodetic_to_ecef(fx.lat, fx.lon, zero + 1.0) - self._r0
        self._label_sets: dict[tuple, np.ndarray] = {}
        #: `_composed_noise` of the cycles' steps, by their bytes.
        self._composed: dict[bytes, tuple[float, float, float, float]] = {}

    def step(self, hyps, a: int, b: int, epoch: int | None) -> CycleOutcome:
        """Propagate every hypothesis from sample `a` to sample `b` and update it there
        with epoch `epoch`'s fix (None: no epoch)."""
        keys = [h.pieces[0][:2] for h in hyps]
        x = np.array([h.x for h in hyps], dtype=float)
        P = np.array([h.P for h in hyps], dtype=float)
        P = self._propagate(x, P, np.diff(self.t[a:b + 1]))
        fix = -1 if epoch is None else self.schedule.split(epoch)[1]
        screens = evidence = whole = None
        rows = 0
        pt = self.grid.points(keys, x[:, 0])
        if fix >= 0:
            x, P, screens, evidence, rows = self._update(keys, x, P, pt, fix)
            if rows and self.bias_sigma_m > 0.0:
                evidence, whole = with_fix_bias(
                    hyps, pt["A"], screens.keys, screens.nu, screens.variances, evidence,
                    float(self.t[b]), sigma_m=self.bias_sigma_m, tau_s=self.bias_tau_s)
        for k, h in enumerate(hyps):
            h.x, h.P = x[k].copy(), P[k].copy()
        points = None               # one hypothesis has nothing abreast (hypothesis_points)
        if len(hyps) > 1:
            points = (pt["r"], np.einsum("kij,kj->ki", pt["C"], pt["u"]))
        return CycleOutcome(screens, None, None, (b - a) * len(hyps), False,
                            evidence=evidence, evidence_rows=rows, points=points,
                            evidence_whole=whole)

    def _propagate(self, x: Array, P: Array, steps: Array) -> Array:
        """``x`` in place and the new ``P`` after the steps (module docstring): the
        engine's steps composed, ``P ← Φ(T) P Φ(T)ᵀ + Σ_j Φ(τ_j) Q_j Φ(τ_j)ᵀ`` with ``τ_j``
        the time left after step j (one Q for all hypotheses)."""
        if steps.size == 0:
            return P
        key = steps.tobytes()             # cycles repeat their steps (a fix rate)
        found = self._composed.get(key)
        if found is None:
            found = self._composed_noise(steps)
            if len(self._composed) >= MAX_KEY_SETS:
                self._composed.clear()
            self._composed[key] = found
        total, Q_ss, Q_sv, Q_vv = found
        x[:, 0] += x[:, 1] * total
        out = P.copy()
        out[:, 0, 0] = P[:, 0, 0] + 2.0 * total * P[:, 0, 1] + total * total * P[:, 1, 1] + Q_ss
        out[:, 0, 1] = out[:, 1, 0] = P[:, 0, 1] + total * P[:, 1, 1] + Q_sv
        out[:, 1, 1] = P[:, 1, 1] + Q_vv
        return out

    def _composed_noise(self, steps: Array) -> tuple[float, float, float, float]:
        """The steps' total time and ``Σ_j Φ(τ_j) Q_j Φ(τ_j)ᵀ``'s ``ss, sv, vv`` (`_propagate`)."""
        q = self.q
        total = float(steps.sum())
        left = total - np.cumsum(steps)
        # Q_j = q dt [[dt²/4, dt/2], [dt/2, 1]], carried to the cycle's end by Φ(τ)
        a = steps * steps / 4.0 + steps * left + left * left
        b = steps / 2.0 + left
        return total, q * float(np.sum(steps * a)), q * float(np.sum(steps * b)), q * total

    def _rows(self, pt: dict, x: Array, f: int):
        """The fix rows at the prior: names, innovations (K, m), ∂h/∂[s, v] (K, m, 2) and
        variances (K, m) (`railnav.filters.fix_rows`)."""
        fx, cfg = self.fixes, self.config.fix_model
        has_h = cfg.use_height and bool(np.isfinite(fx.h_m[f]))
        ax = _axes(pt, up=has_h)
        h = np.full(x.shape[0], fx.h_m[f]) if has_h else pt["h"]
        r_fix = self._r0[f] + h[:, None] * self._normal[f]
        d_n = np.einsum("kji,kj->ki", pt["C"], r_fix - pt["r"])
        cov = fx.cov_n_m2[f]
        K = x.shape[0]
        along = ax["along"] if has_h else ax["along_h"]
        spec = [("fix_along", along, 0.0, _dot(along, pt["u"]))]
        spec.append(("fix_cross", ax["cross"], cfg.track_cross_sigma_m ** 2, np.zeros(K)))
        if has_h:
            spec.append(("fix_up", ax["up"], cfg.track_vertical_sigma_m ** 2, np.zeros(K)))
        names, nu, H, R = [], [], [], []
        for kind, a, extra, h_s in spec:
            names.append(kind)
            nu.append(_dot(a, d_n))
            H.append((h_s, None))                    # ∂/∂v: 0
            R.append(np.einsum("ki,ij,kj->k", a, cov, a) + extra)
        v = fx.v_n_mps[f]
        if cfg.use_speed and np.all(np.isfinite(v[:2])):
            a = ax["along"] if np.isfinite(v[2]) else ax["along_h"]
            au = _dot(a, pt["u"])
            names.append("fix_speed")
            nu.append(a @ np.nan_to_num(v) - x[:, 1] * au)
            H.append((x[:, 1] * _dot(a, pt["du"]), au))
            R.append(np.full(K, float(fx.sigma_speed_mps[f]) ** 2))
        return names, np.stack(nu, 1), H, np.stack(R, 1)

    @staticmethod
    def _jacobian(H: list) -> Array:
        """`_rows`' ``(∂/∂s, ∂/∂v)`` of each row (None: 0) as (K, m, 2)."""
        K = H[0][0].shape[0]
        return np.stack([np.column_stack([h_s, np.zeros(K) if h_v is None else h_v])
                         for h_s, h_v in H], 1)

    def _update(self, keys, x: Array, P: Array, pt: dict, f: int):
        """Screen, gate and update with fix `f`; the evidence (module docstring)."""
        names, nu, H, R = self._rows(pt, x, f)
        if "fix_speed" not in names:                 # one row on s: scalar arithmetic
            return self._scalar_update(names, x, P, nu, H[0][0], R, f)
        H = self._jacobian(H)
        S = np.einsum("kma,kab,knb->kmn", H, P, H) + np.einsum("km,mn->kmn", R,
                                                               np.eye(R.shape[1]))
        r2 = nu ** 2 / np.diagonal(S, axis1=1, axis2=2)
        passed = np.ones(x.shape[0], bool) if self.screen_nis is None else \
            np.all(r2 <= self.screen_nis, axis=1)
        kept = passed[:, None] & (True if self.gate_nis is None else r2 <= self.gate_nis)
        Hk = H * kept[..., None]
        Sk = np.einsum("kma,kab,knb->kmn", Hk, P, Hk) + np.einsum("km,mn->kmn", R,
                                                                  np.eye(R.shape[1]))
        gain = np.linalg.solve(Sk, np.einsum("kab,kmb->kma", P, Hk)).transpose(0, 2, 1)
        x = x + np.einsum("kam,km->ka", gain, nu)
        A = np.eye(2)[None] - np.einsum("kam,kmb->kab", gain, Hk)
        P = np.einsum("kab,kbc,kdc->kad", A, P, A) + np.einsum("kam,km,kbm->kab", gain, R, gain)
        P = 0.5 * (P + P.transpose(0, 2, 1))
        labels = self._labels(names, f)
        screens = StackedScreens(labels, nu, S, kept, self.config.fault_detection)
        if not passed.any():
            return x, P, screens, np.zeros(x.shape[0]), 0
        L = np.linalg.cholesky(S)
        white = np.linalg.solve(L, nu[..., None])[..., 0]
        log_det = 2.0 * np.sum(np.log(np.diagonal(L, axis1=1, axis2=2)), axis=1)
        evidence = -0.5 * (np.sum(white ** 2, axis=1) + log_det + nu.shape[1] * LOG_2PI)
        return x, P, screens, evidence, int(nu.shape[1])

    def _labels(self, names, f: int):
        """The row keys of fix `f` (``fix_sv/QUALITY/kind``), one array per quality and
        kinds (read-only: shared by the cycles)."""
        key = (str(self.fixes.quality[f]), tuple(names))
        out = self._label_sets.get(key)
        if out is None:
            out = np.array([f"{FIX_SV_PREFIX}{key[0]}/{n}" for n in names], dtype=object)
            out.flags.writeable = False
            self._label_sets[key] = out
        return out

    def _scalar_update(self, names, x: Array, P: Array, nu: Array, h: Array, R: Array,
                       f: int):
        """`_update` when only the along row depends on the state (``∂/∂s = h``): the
        innovation covariance is diagonal, the update scalar."""
        var = R.copy()
        var[:, 0] += h * h * P[:, 0, 0]
        r2 = nu ** 2 / var
        passed = np.ones(x.shape[0], bool) if self.screen_nis is None else \
            np.all(r2 <= self.screen_nis, axis=1)
        kept = passed[:, None] & (True if self.gate_nis is None else r2 <= self.gate_nis)
        use = kept[:, 0]
        gain = np.where(use[:, None], P[:, :, 0] * (h / var[:, 0])[:, None], 0.0)   # (K, 2)
        x = x + gain * nu[:, :1]
        P = P - np.einsum("ka,kb->kab", gain, gain) * var[:, 0][:, None, None]
        P = 0.5 * (P + P.transpose(0, 2, 1))
        labels = self._labels(names, f)
        screens = StackedScreens(labels, nu, None, kept, self.config.fault_detection,
                                 variances=var)          # S = diag(var), made when read
        if not passed.any():
            return x, P, screens, np.zeros(x.shape[0]), 0
        evidence = -0.5 * np.sum(r2 + np.log(var) + LOG_2PI, axis=1)
        return x, P, screens, evidence, int(nu.shape[1])
