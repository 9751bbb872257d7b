"""First guess of a fit: the pieces of a profile read off a smooth reference.

Horizontally, the running integral ``Y(σ) = ∫ A_ref`` of a reference azimuth
(`trackmodel.reference`) is, to first order in the azimuth *error*, the lateral position:
a straight leaves ``Y`` linear in σ, an arc quadratic, a clothoid cubic. Vertically the
height itself plays that part: a constant grade is linear, a vertical curve quadratic. So
the least-squares polynomial of degree 1, 2 or 3 (with a free constant) fitted to ``Y``
over a stretch measures in metres how far that piece, at its best start, strays from the
reference.

`segment` cuts ``Y`` into the fewest such pieces whose RMS deviation is at most ``rms_m``
(dynamic programming over candidate joints a few metres apart; the power sums behind all
candidate pieces that end at a joint are running sums, so each joint costs one batched
solve of small normal equations). Among segmentations of equal count it prefers the lower
degrees (`KIND_COST`: straights, then arcs, then transitions) and then the smaller
deviations. `fit_values` then sets the start offset, the start azimuth and the values of a
layout by linear least squares on the whole of ``Y``, so that the first guess follows the
reference as a whole (no drift from piece to piece).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from trackmodel.pieces import CONST, FREE, RAMP, ZERO, Pieces, Shape

__all__ = ["segment", "fit_values", "running_integral", "HORIZONTAL_KINDS", "VERTICAL_KINDS"]

Array = npt.NDArray[np.float64]

#: Cost of a piece by polynomial degree: counts first, then simplicity.
KIND_COST = {1: 1.0, 2: 1.1, 3: 1.2}
#: Weight of a piece's normalised squared deviation (≤ 1) in the cost: breaks ties only.
DEVIATION_COST = 0.05
#: Piece kind of each polynomial degree of Y: horizontally (Y = ∫ azimuth: straight, arc,
#: clothoid with its own end curvatures) and vertically (Y = height: grade, vertical curve).
HORIZONTAL_KINDS = {1: ZERO, 2: CONST, 3: FREE}
VERTICAL_KINDS = {1: CONST, 2: RAMP}
#: At most this many candidate joints, and a piece spans at most `WINDOW` of them.
MAX_CANDIDATES = 2000
WINDOW = 400
#: Relative ridge on the (Jacobi-scaled) normal equations of the piece fits.
RIDGE = 1e-12
#: A vertical joint of two grades gets a vertical curve of this fraction of the shorter one.
JOINT_RAMP_FRACTION = 0.25


def running_integral(sigma: Array, f: Array) -> Array:
    """Trapezoidal ``∫₀^σ f`` along the first axis."""
    cells = 0.5 * (f[1:] + f[:-1]) * np.diff(sigma).reshape((-1,) + (1,) * (f.ndim - 1))
    return np.concatenate([np.zeros((1,) + f.shape[1:]), np.cumsum(cells, axis=0)])


def _deviations(x: Array, y: Array, j: int, lo: int, degrees) -> dict[int, Array]:
    """Sum of squared residuals of the polynomial fits of y over samples i..j, for every
    start i in lo..j-1 (shape (j - lo,) each), by degree."""
    u = (x[lo:j + 1] - x[j]) / max(x[j] - x[lo], 1e-12)            # in [-1, 0]
    v = y[lo:j + 1] - y[j]
    U = u[:, None] ** np.arange(7)
    S = np.cumsum(U[::-1], axis=0)[::-1][:-1]                        # Σ_{k=i}^{j} u^p
    T = np.cumsum((U[:, :4] * v[:, None])[::-1], axis=0)[::-1][:-1]
    Q = np.cumsum((v * v)[::-1])[::-1][:-1]
    out = {}
    for d in degrees:
        p = np.arange(d + 1)
        G = S[:, p[:, None] + p[None, :]]
        scale = np.sqrt(np.diagonal(G, axis1=1, axis2=2))
        G = G / (scale[:, :, None] * scale[:, None, :]) + RIDGE * np.eye(d + 1)
        b = T[:, :d + 1] / scale
        coef = np.linalg.solve(G, b[..., None])[..., 0]
        out[d] = np.maximum(Q - np.einsum("ij,ij->i", b, coef), 0.0)
    return out


def segment(sigma: Array, Y: Array, rms_m: float, kinds: dict[int, int], *,
            continuous: bool = False) -> Shape:
    """Fewest pieces of the given kinds that follow a reference.

    Parameters
    ----------
    sigma : ndarray, shape (K,)
        Sample positions, m, increasing from 0.
    Y : ndarray, shape (K,)
        The lateral-equivalent ``∫ A_ref`` (horizontal) or the height (vertical), m.
    rms_m : float
        Largest RMS deviation of a piece from Y, m.
    kinds : dict
        Piece kind for each polynomial degree allowed (`HORIZONTAL_KINDS`,
        `VERTICAL_KINDS`).
    continuous : bool
        The profile must not jump (vertical): a short ramp is put between two neighbouring
        pieces that are not ramps.

    Returns
    -------
    Shape
        Layout and lengths (values zero: see `fit_values`).
    """
    stride = max(1, int(np.ceil(len(sigma) / MAX_CANDIDATES)))
    index = np.unique(np.append(np.arange(0, len(sigma), stride), len(sigma) - 1))
    index = index[np.diff(sigma[index], append=np.inf) > 0]      # one joint per position
    x, y = sigma[index], Y[index]
    n = len(x)
    best = np.full(n, np.inf)
    best[0] = 0.0
    origin, degree = np.zeros(n, dtype=np.intp), np.zeros(n, dtype=np.intp)
    for j in range(1, n):
        lo = max(0, j - WINDOW)
        starts = np.arange(lo, j)
        count = (j - starts + 1).astype(float)
        for d, sse in _deviations(x, y, j, lo, tuple(kinds)).items():
            ratio = sse / (count * rms_m * rms_m)
            total = np.where(ratio <= 1.0, best[starts] + KIND_COST[d]
                             + DEVIATION_COST * ratio, np.inf)
            k = int(np.argmin(total))
            if total[k] < best[j]:
                best[j], origin[j], degree[j] = total[k], starts[k], d
    ends, found = [], []
    j = n - 1
    while j > 0:
        ends.append(x[j])
        found.append(kinds[int(degree[j])])
        j = origin[j]
    lengths = np.diff(np.concatenate([[0.0], ends[::-1]]))
    return _layout(found[::-1], lengths, continuous)


def _layout(kinds: list[int], lengths: Array, continuous: bool) -> Shape:
    """Shape of the segmentation (see `Shape.build`); if `continuous`, a ramp of
    `JOINT_RAMP_FRACTION` of the shorter neighbour at each joint of two non-ramps."""
    if continuous:
        out_k, out_L = [kinds[0]], [lengths[0]]
        for kind, L in zip(kinds[1:], lengths[1:]):
            if kind != RAMP and out_k[-1] != RAMP:
                cut = JOINT_RAMP_FRACTION * min(out_L[-1], L)
                out_L[-1] -= cut
                out_k.append(RAMP)
                out_L.append(2.0 * cut)
                L -= cut
            out_k.append(kind)
            out_L.append(L)
        kinds, lengths = out_k, np.array(out_L)
    zero = np.zeros(len(kinds))
    return Shape.build(kinds, lengths, zero, zero, continuous=continuous)


def value_basis(pieces: Pieces, sigma: Array) -> tuple[Array, Array]:
    """``∂f(σ)/∂a_j`` and ``∂f(σ)/∂b_j`` of a piecewise-linear profile f for the start and
    end values of every piece, shape (K, m) each."""
    L = pieces.lengths
    t = sigma[:, None] - pieces.knots[None, :-1]
    inside = (t >= 0.0) & (t < L[None, :])
    inside[sigma >= pieces.knots[-1], -1] = True
    u = np.where(inside, t / L, 0.0)
    return np.where(inside, 1.0 - u, 0.0), u


def fit_values(sigma: Array, Y: Array, shape: Shape, *, integrations: int) -> tuple[Array, Shape]:
    """Start terms and free values of a layout that follow Y (linear least squares).

    ``Y`` is modelled as the `integrations`-fold running integral of the profile plus a
    polynomial of degree ``integrations − 1`` (horizontal, 2: ``Y = c + A0 σ + ∫∫κ``;
    vertical, 1: ``h = h0 + ∫ϑ``, small angles), linear in these terms and in the values
    for the shape's fixed lengths.

    Returns
    -------
    terms : ndarray, shape (integrations,)
        The polynomial's coefficients, lowest first (c, A0) or (h0,).
    shape : Shape
        With the fitted values.
    """
    da, db = value_basis(shape.layout.pieces(shape.lengths, np.zeros(shape.layout.n_values)),
                         sigma)
    B = shape.layout.value_jacobian(da, db)
    for _ in range(integrations):
        B = running_integral(sigma, B)
    B = np.column_stack([sigma[:, None] ** np.arange(integrations), B])
    scale = np.maximum(np.linalg.norm(B, axis=0), 1e-300)
    Bs = B / scale
    x = np.linalg.solve(Bs.T @ Bs + RIDGE * np.eye(B.shape[1]), Bs.T @ Y) / scale
    return x[:integrations], Shape(shape.layout, shape.lengths, x[integrations:])
