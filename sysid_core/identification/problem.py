r"""The fit problem: scaled data, the linear equation-error operator, and conic-program pieces.

Scaling (see docs/fitting.md): with the band centre :math:`\omega_0`,
:math:`\Omega=\omega/\omega_0`,
:math:`\delta=\Omega^2-1` and :math:`\varepsilon=\max|\delta|`, the unknowns are written

.. math::

    K_c = \omega_0^2 (M + \varepsilon \tilde D_0),\quad
    K_p = \omega_0^2 \varepsilon \tilde K_p / s_p,\quad
    C = \omega_0 \varepsilon \tilde C,\quad
    P(\nu) = s_\psi \textstyle\sum_l \tilde P_l \nu^l,

where :math:`K_c = K_0 + \sum_p K_p \bar w_p` is the stiffness at the mean squared potentials
:math:`\bar w`, :math:`\tilde w_p = (w_p - \bar w_p)/s_p`, and
:math:`\nu = (\omega-\omega_0)/h` with :math:`h=\max|\omega-\omega_0|`. Then
:math:`Z = \omega_0^2\varepsilon\,\tilde Z` with
:math:`\tilde Z = \tilde D_0 + \sum_p \tilde w_p \tilde K_p - (\delta/\varepsilon) M +
j\Omega\tilde C`, and with :math:`\tilde\psi = \psi\,\omega_0^2\varepsilon/s_\psi` the
equation error is :math:`E = s_\psi (\tilde P - \tilde\psi\tilde Z)` (act) or
:math:`s_\psi(\tilde P - \tilde Z\tilde\psi)` (sen). Every unknown is then O(1e-3 … 1); the
centring removes the near-cancellation of :math:`M\omega^2` and :math:`K_0`.

The scaled unknowns form the vector :math:`\theta` (layout in :class:`ParameterLayout`), and the
equation error at every data point is linear in it: :math:`E_i = G_i\theta`.

Noise weights: when every data point has a noise variance (the data set's ``noise_var``,
:mod:`sysid_core.data.schema`), point :math:`i`'s rows are multiplied by
:math:`w_i = v_i^{-1/2}`, :math:`v_i` the mean of its four channels' variances, normalised so
that :math:`\operatorname{mean}_i w_i^2 = 1`: a response's noise :math:`n` enters the equation
error as :math:`n Z` (or :math:`Z n`), so a point's equation-error noise is proportional to its
response noise, and the weighted errors have the same noise level everywhere. Equal variances
(or a point without one) leave the rows as they are. Everything computed from ``G`` (the
objectives, ``gram``, ``residuals``, the covariance) sees the weighted problem.

Point weights (``point_weights``) multiply the noise weights: the refit of
:mod:`sysid_core.identification.reweighting` weights each point by ``1/‖Z‖`` of a previous fit,
since the noise enters the equation error multiplied by ``Z``.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import xarray as xr

from sysid_core.conic.program import SYM_BASIS, sigma_max_2x2
from sysid_core.data.schema import RESPONSE_DIMS, measured_mask, squared_potentials
from sysid_core.data.validation import check_rank_condition, validate
from sysid_core.errors import DataError
from sysid_core.identification.scaling import ParameterLayout, Scaling
from sysid_core.model.structures import ModelStructure

__all__ = [
    "EPS_DAMPING",
    "EPS_STIFFNESS",
    "FitProblem",
    "ParameterLayout",
    "Scaling",
    "noise_weights",
]

#: Strict inequality C > 0 becomes C ⪰ EPS_DAMPING·ω0·ε·I (scaled: C̃ ⪰ EPS_DAMPING·I);
#: it bounds Q below about 1/(ε·EPS_DAMPING) ≈ 1e9 for a 1.4 % band.
EPS_DAMPING = 1e-8
#: Strict inequality K(w_k) > 0 becomes K(w_k) ⪰ EPS_STIFFNESS·ω0²·I at every experiment's bias.
EPS_STIFFNESS = 1e-6


def noise_weights(
    dataset: xr.Dataset, experiment: np.ndarray, frequency: np.ndarray
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Each point's noise variance and the weight of its equation errors (module docstring).

    The variance of a sweep is pooled over its points and channels (an estimate from a few
    hundred degrees of freedom or more, a few per cent from its truth), and the sweeps are
    weighted only when the data say their noise differs: the largest pooled variance over
    the smallest above :data:`VARIANCE_RATIO`. Sweeps of the same noise are then fitted
    exactly as without ``noise_var`` (weights drawn from estimates of equal variances would
    only add their scatter).

    Parameters
    ----------
    dataset : xarray.Dataset
        Validated data, with or without ``noise_var``.
    experiment, frequency : ndarray of int
        The points: indices into the data set's ``experiment`` and ``frequency``.

    Returns
    -------
    variance : ndarray or None
        Per point, its sweep's pooled ``noise_var``; ``None`` unless every point has a
        finite, positive one.
    weights : ndarray or None
        ``v^{-1/2}`` normalised to a mean square of 1 over the points; ``None`` (no weighting)
        without ``variance`` or when the sweeps' variances differ by less than
        :data:`VARIANCE_RATIO`.
    """
    if "noise_var" not in dataset:
        return None, None
    table = np.asarray(dataset["noise_var"].transpose(*RESPONSE_DIMS).values, dtype=float)
    point = table[experiment, frequency].mean(axis=(1, 2))
    if not point.size or not np.all(np.isfinite(point) & (point > 0)):
        return None, None
    sweeps = np.unique(experiment)
    pooled = np.array([point[experiment == k].mean() for k in sweeps])
    variance = pooled[np.searchsorted(sweeps, experiment)]
    if pooled.max() <= VARIANCE_RATIO * pooled.min():
        return variance, None
    weights = 1.0 / np.sqrt(variance)
    return variance, weights / np.sqrt(np.mean(weights**2))


#: Sweeps are weighted by their noise only when their pooled variances differ by more than
#: this factor (a sweep of 11 points from 16 sub-samples per point has a pooled estimate
#: within a few per cent of its truth; √2 more noise in one sweep is a factor of 2).
VARIANCE_RATIO = 1.5


class FitProblem:
    """Data and structure, scaled, with the linear map from unknowns to equation errors.

    Parameters
    ----------
    dataset : xarray.Dataset
        Validated data (see :mod:`sysid_core.data.schema`).
    structure : ModelStructure
        The model structure (``act`` or ``sen``) with its polynomial order.
    drift_rate : float
        A common frequency drift to undo (relative, per second of the device's clock): each
        point's frequency is mapped to the gyro at the latest time stamp. Needs ``time_s`` at
        every point. Default 0: no drift.
    offsets : bool
        Common drift offsets: with an ``epoch`` coordinate (per experiment, larger is later),
        the stiffness of every earlier epoch's sweeps is the latest epoch's plus ``δ_e ω0²``
        times ``mass_shape`` (one unknown each, linear in the equation error: both modes move
        together, as with temperature); the model is the gyro of the latest epoch. Without the
        coordinate, or with one epoch, nothing changes.
    trend : bool
        A stiffness trend in time: every point's stiffness differs from the gyro's at the latest
        time stamp by ``(t − t_ref) D_t`` with an unknown symmetric ``D_t`` (3 unknowns: the
        common and the split's drift, and charging's, to first order). Needs ``time_s``.
    mass_shape : array, optional
        The shape of a common offset: the mass matrix of an earlier fit (default: identity).
    """

    def __init__(
        self,
        dataset: xr.Dataset,
        structure: ModelStructure,
        drift_rate: float = 0.0,
        offsets: bool = False,
        trend: bool = False,
        mass_shape: np.ndarray | None = None,
        point_weights: np.ndarray | None = None,
    ) -> None:
        validate(dataset)
        self.dataset = dataset
        self.structure = structure
        self.electrodes = [str(e) for e in dataset["electrode"].values]
        self.structure_potential = float(dataset.attrs["structure_potential"])
        self.bias = np.asarray(dataset["bias"].values, dtype=float)
        mask = measured_mask(dataset)
        f = np.asarray(dataset["frequency"].values, dtype=float)
        k_idx, q_idx = np.nonzero(mask)
        self.experiment = k_idx
        self.frequency_hz = f[q_idx]
        self.psi = np.asarray(dataset["response"].values)[k_idx, q_idx]
        self.w = squared_potentials(self.structure_potential, self.bias)
        self.omega = 2 * np.pi * self.frequency_hz
        #: Every point's time stamp (the device's clock; None unless every point has one) and
        #: the time the model describes: the latest one.
        self.times_s: np.ndarray | None = None
        self.reference_time_s: float | None = None
        if "time_s" in dataset:
            times = np.asarray(dataset["time_s"].values, dtype=float)[k_idx, q_idx]
            if np.all(np.isfinite(times)) and times.size:
                self.times_s = times
                self.reference_time_s = float(times.max())
        #: The relative frequency drift per second that the fit undoes.
        self.drift_rate = float(drift_rate)
        if (self.drift_rate or trend) and self.times_s is None:
            raise DataError("a drift can be fitted only to data with a time stamp at every point")
        if self.drift_rate:
            assert self.times_s is not None and self.reference_time_s is not None
            # the gyro at time t is the reference gyro with every frequency scaled by
            # 1 + rate·(t − t_ref): it answers at ω as the reference gyro does at ω / (1 + …)
            self.omega = self.omega / (
                1.0 + self.drift_rate * (self.times_s - self.reference_time_s)
            )
        #: The drift terms: a common offset per earlier epoch (the stiffness of its sweeps is
        #: the latest epoch's plus ``δ_e`` times :attr:`mass_shape`) and a stiffness trend in
        #: time (:attr:`trend_scale_s` seconds per unit of its regressor).
        self.mass_shape = np.eye(2) if mass_shape is None else np.asarray(mass_shape, float)
        self.epochs: np.ndarray | None = None
        self.offset_epochs: list[int] = []
        if offsets and "epoch" in dataset.coords:
            self.epochs = np.asarray(dataset["epoch"].values, dtype=int)
            self.offset_epochs = [int(e) for e in np.unique(self.epochs)[:-1]]
        self.trend_scale_s = 0.0
        if trend and self.times_s is not None and np.ptp(self.times_s) > 0:
            self.trend_scale_s = float(np.ptp(self.times_s))
        self.layout = ParameterLayout(
            len(self.electrodes),
            structure.order,
            structure.bias_terms,
            getattr(structure, "stiffness", "linear") == "quadratic",
            len(self.offset_epochs),
            bool(self.trend_scale_s),
        )
        if self.layout.quadratic:
            check_rank_condition(self.bias, self.structure_potential, self.electrodes, True)
        self.scaling = Scaling.from_data(self.omega, self.w, self.psi, self.experiment)
        #: Every point's noise variance (mean over its channels; None unless every point has
        #: one) and the weight of its equation errors (None: all equal), see the module doc.
        self.noise_variance, self.weights = noise_weights(dataset, k_idx, q_idx)
        #: Per point, a weight multiplying the noise weight (None: all equal).
        self.point_weights = None if point_weights is None else np.asarray(point_weights, float)
        if self.point_weights is not None and self.point_weights.shape != (k_idx.size,):
            raise DataError(
                f"point_weights has shape {self.point_weights.shape}; the data have "
                f"{k_idx.size} points: give one weight per measured point"
            )
        self.G = self._operator()

    @property
    def n_points(self) -> int:
        """Number of data points (all experiments)."""
        return int(self.psi.shape[0])

    @property
    def n_experiments(self) -> int:
        """Number of experiments."""
        return int(self.bias.shape[0])

    @property
    def n_parameters(self) -> int:
        """Number of real unknowns (the scaled ``theta``)."""
        return self.layout.n

    def scaled_w(self) -> np.ndarray:
        """Scaled squared potentials ``w~`` per experiment, ``(n_exp, n_e)``."""
        return self.scaling.scaled_w(self.w)

    def scaled_q(self) -> np.ndarray:
        """The quadratic law's regressors ``φ``, ``(n_exp, n_e)`` (see :class:`Scaling`)."""
        return self.scaling.scaled_q(self.w)

    def _operator(self) -> np.ndarray:
        """``G`` with shape ``(N, 8, n)``: rows Re E11..E22 then Im E11..E22.

        Each point's rows are multiplied by its noise weight, if any (``weights``).
        """
        s, lay = self.scaling, self.layout
        n_pts = self.n_points
        big_omega = self.omega / s.omega0
        d_eps = (big_omega**2 - 1) / s.eps
        nu = (self.omega - s.omega0) / s.nu_half
        psi_t = self.psi * (s.omega0**2 * s.eps / s.psi_scale)
        wt = self.scaled_w()[self.experiment]  # (N, n_e)
        # product(psi~, S_a) for the three symmetric basis matrices: (N, 3, 2, 2)
        prod = self.structure.product(psi_t[:, None], SYM_BASIS[None].astype(complex))
        g = np.zeros((n_pts, 2, 2, lay.n), dtype=complex)
        # Z~ = D~ + sum w~ K~ - (delta/eps) M + j Omega C~ ; E = P~ - product(psi~, Z~)
        coef = [
            (lay.M, -d_eps.astype(complex)),
            (lay.C, 1j * big_omega),
            (lay.D, np.ones(n_pts, dtype=complex)),
        ]
        coef += [(lay.K(p), wt[:, p].astype(complex)) for p in range(lay.n_electrodes)]
        if lay.quadratic:
            qt = self.scaled_q()[self.experiment]
            coef += [(lay.L(p), qt[:, p].astype(complex)) for p in range(lay.n_electrodes)]
        if lay.trend:
            assert self.times_s is not None and self.reference_time_s is not None
            tau = (self.times_s - self.reference_time_s) / self.trend_scale_s
            coef.append((lay.T, tau.astype(complex)))
        for sl, c in coef:
            for a in range(3):
                g[:, :, :, sl.start + a] = -c[:, None, None] * prod[:, a]
        if self.epochs is not None and lay.n_offsets:
            # δ_e S with the fixed shape S, scaled as D~ (the unknown is δ_e / ε): one column
            # each, -[epoch e] product(psi~, S)
            shaped = self.structure.product(psi_t, self.mass_shape[None].astype(complex))
            point_epoch = self.epochs[self.experiment]
            for j, e in enumerate(self.offset_epochs):
                here = (point_epoch == e)[:, None, None]
                g[:, :, :, lay.offset(j).start] = -np.where(here, shaped, 0.0)
        blocks = [(lay.poly(deg), nu**deg) for deg in range(lay.order + 1)]
        blocks += [
            (lay.poly_w(deg, p), nu**deg * wt[:, p])
            for deg in range(lay.bias_terms)
            for p in range(lay.n_electrodes)
        ]
        for sl, factor in blocks:
            for e in range(4):
                r, col = divmod(e, 2)
                g[:, r, col, sl.start + e] = factor
                g[:, r, col, sl.start + 4 + e] = 1j * factor
        flat = g.reshape(n_pts, 4, lay.n)
        rows = np.concatenate([flat.real, flat.imag], axis=1)
        for weights in (self.weights, self.point_weights):
            rows *= 1.0 if weights is None else weights[:, None, None]
        return np.ascontiguousarray(rows)

    # ----------------------------------------------------------------- evaluation
    def errors(self, theta: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Complex equation errors ``(N, 2, 2)`` in scaled units at ``theta`` (weighted)."""
        g = self.G if points is None else self.G[points]
        e = g @ theta
        return (e[:, :4] + 1j * e[:, 4:]).reshape(-1, 2, 2)

    def residuals(self, theta: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """σ̄(E) at every data point (scaled units, weighted)."""
        return sigma_max_2x2(self.errors(theta, points))

    @cached_property
    def gram(self) -> np.ndarray:
        """``sum_i G_i^T G_i / N``: the least-squares objective is ``theta^T gram theta``."""
        g = self.G.reshape(-1, self.layout.n)
        return (g.T @ g) / self.n_points

    def normal_condition(self, law_basis: bool = False) -> float:
        """Condition number of the equilibrated normal matrix of the unknowns other than ``M``.

        The normal matrix is :attr:`gram` restricted to every unknown but ``M`` (which fixes
        the scale), scaled to a unit diagonal (the 2-norm condition of a least-squares problem
        after column equilibration). With ``law_basis`` and the quadratic law, it is computed
        for the plain centred basis ``x_p``, ``x_p² − mean(x_p²)`` instead of the orthogonal
        ``φ_p``: a large value there says the design barely separates ``w_p²`` from ``w_p``
        (e.g. two levels of one electrode a hair apart), i.e. the law is not identified, even
        though the orthogonal basis keeps the solve itself well conditioned.
        """
        lay = self.layout
        g = self.gram
        if law_basis and lay.quadratic:
            g = self._monomial_transform().T @ g @ self._monomial_transform()
        free = np.ones(lay.n, dtype=bool)
        free[lay.M] = False
        sub = g[np.ix_(free, free)]
        d = np.sqrt(np.clip(np.diag(sub), 1e-300, None))
        lam = np.linalg.eigvalsh(sub / np.outer(d, d))
        return float(lam[-1] / lam[0]) if lam[0] > 0 else float("inf")

    def _monomial_transform(self) -> np.ndarray:
        """``T`` with ``theta = T theta_mono``: the quadratic law in plain centred monomials.

        ``theta_mono`` has the quadratic law's unknowns ``L~_p`` multiplying ``x_p² − mean(x_p²)``
        instead of ``φ_p``.
        """
        lay, s = self.layout, self.scaling
        assert s.q_basis is not None
        x = self.scaled_w()[self.experiment]
        mean_sq = (x**2).mean(axis=0)
        t = np.eye(lay.n)
        for p, (a, b, h) in enumerate(s.q_basis):
            # x² − m = h φ + (a − m) + b x
            lp, kp = lay.L(p), lay.K(p)
            t[lp, lp] = h * np.eye(3)
            t[lay.D, lp] = (a - mean_sq[p]) * np.eye(3)
            t[kp, lp] = b * np.eye(3)
        return t

    @cached_property
    def objective_scale(self) -> float:
        """A typical value of ``theta^T gram theta`` near the optimum (for conditioning).

        The minimum with ``M = I`` fixed and every other unknown free: a linear solve. Quadratic
        objectives are divided by it so that their optimal value is O(1) whatever the noise
        level (an O(1e-8) optimum stalls interior-point solvers at their absolute tolerances).
        """
        g = self.gram
        m = np.zeros(self.layout.n, dtype=bool)
        m[self.layout.M] = True
        fixed = np.array([1.0, 0.0, 1.0])
        rhs = -g[np.ix_(~m, m)] @ fixed
        free, *_ = np.linalg.lstsq(g[np.ix_(~m, ~m)], rhs, rcond=None)
        theta = np.zeros(self.layout.n)
        theta[m], theta[~m] = fixed, free
        value = float(theta @ g @ theta)
        return value if np.isfinite(value) and value > 1e-300 else 1.0
