"""The first-order additive Matérn 5/2 kernel: one one-dimensional Matérn 5/2 term per design variable,

    k(x, y) = Σ_j s_j · m(|x_j − y_j| / l_j),    m(r) = (1 + √5 r + 5r²/3) · exp(−√5 r),

with a variance ``s_j`` and a length scale ``l_j`` per variable (Duvenaud, Nickisch & Rasmussen, *Additive
Gaussian processes*, NeurIPS 2011, the first-order term). Summed with the usual product kernel (one length
scale per variable over all of them at once) it lets the marginal likelihood weigh a response made of
one-variable effects against one where the variables interact; scikit-learn has no kernel restricted to one
input column, hence this one, written to its :class:`~sklearn.gaussian_process.kernels.Kernel` interface
(log-hyperparameters, analytic gradient) so that its optimiser fits it like any other.

:class:`WarpedAdditiveMatern` applies the same terms to each variable after a monotone warping of its unit
range, the Kumaraswamy distribution function w(x) = 1 − (1 − x^a)^b with ``a``, ``b`` fitted per variable
(Snoek, Swersky, Zemel & Adams, *Input warping for Bayesian optimization of non-stationary functions*,
ICML 2014): a one-variable effect that is flat over most of the range and changes fast in a corner of it
(a response of x¹³, say) becomes one a stationary term can learn, and the corner's uncertainty grows with
the stretch, so an optimistic search goes to look there.
"""

from __future__ import annotations

import numpy as np
from sklearn.gaussian_process.kernels import Hyperparameter, Kernel, StationaryKernelMixin

SQRT5 = np.sqrt(5.0)
#: How far inside the unit interval the warping clips its inputs (log x and log(1 − x^a) stay finite).
WARP_MARGIN = 1e-9


class AdditiveMatern(StationaryKernelMixin, Kernel):
    """``Σ_j s_j · m(|x_j − y_j| / l_j)`` over the columns of the inputs (module docstring).

    variances: ``s_j`` per variable (an array of the number of columns); length_scales: ``l_j`` per variable,
    in the inputs' unit; the bounds apply to every element."""

    def __init__(self, variances=(0.1,), length_scales=(0.3,), variances_bounds=(1e-4, 1e3),
                 length_scales_bounds=(1e-3, 1e2)):
        self.variances = variances
        self.length_scales = length_scales
        self.variances_bounds = variances_bounds
        self.length_scales_bounds = length_scales_bounds

    # scikit-learn orders a kernel's log-hyperparameters by attribute name: length scales, then variances
    @property
    def hyperparameter_length_scales(self) -> Hyperparameter:
        return Hyperparameter("length_scales", "numeric", self.length_scales_bounds, len(self.length_scales))

    @property
    def hyperparameter_variances(self) -> Hyperparameter:
        return Hyperparameter("variances", "numeric", self.variances_bounds, len(self.variances))

    def __call__(self, X, Y=None, eval_gradient=False):
        X = np.atleast_2d(X)
        if eval_gradient and Y is not None:
            raise ValueError("the gradient is only defined for Y=None")
        s = np.asarray(self.variances, float)
        # (n, m, d) arrays, a few MB each in a campaign's screening: computed in place, in the order of the
        # formulas' terms, so that the values are those of the plain expressions, bit for bit
        r = X[:, None, :] - (X if Y is None else np.atleast_2d(Y))[None, :, :]
        np.abs(r, out=r)
        r /= np.asarray(self.length_scales, float)
        e = np.multiply(-SQRT5, r)
        np.exp(e, out=e)                                   # e^{−√5 r}
        m = np.multiply(SQRT5, r)
        m += 1.0
        t = np.multiply(5.0 / 3.0, r)
        t *= r
        m += t
        m *= e                                             # (1 + √5 r + 5r²/3) e^{−√5 r}
        K = m @ s
        if not eval_gradient:
            return K
        # d k / d log l_j = s_j · (5/3) r² (1 + √5 r) e^{−√5 r};  d k / d log s_j = s_j · m
        d_length = np.multiply(s * (5.0 / 3.0), r)
        d_length *= r
        t = np.multiply(SQRT5, r, out=t)
        t += 1.0
        d_length *= t
        d_length *= e
        m *= s
        return K, np.concatenate([d_length, m], axis=2)

    def diag(self, X):
        return np.full(np.shape(X)[0], float(np.sum(self.variances)))

    def __repr__(self) -> str:
        return (f"AdditiveMatern(variances={np.round(np.asarray(self.variances, float), 4).tolist()}, "
                f"length_scales={np.round(np.asarray(self.length_scales, float), 4).tolist()})")


class WarpedAdditiveMatern(AdditiveMatern):
    """``Σ_j s_j · m(|w_j(x_j) − w_j(y_j)| / l_j)``, ``w_j(x) = 1 − (1 − x^{a_j})^{b_j}`` (module docstring).

    The inputs are in the unit box (clipped to it, a hair inside, so that the logarithms of the gradient stay
    finite); warping_a, warping_b: ``a_j``, ``b_j`` per variable (1, 1: no warping); warping_bounds apply to
    every one of them: from 0.1 to 30, a stretch of the bottom of a range to one of its top tenth (0.9³⁰ =
    0.04, so ``a = 30`` spreads the top tenth over nearly all of w)."""

    def __init__(self, variances=(0.1,), length_scales=(0.3,), warping_a=(1.0,), warping_b=(1.0,),
                 variances_bounds=(1e-4, 1e3), length_scales_bounds=(1e-3, 1e2), warping_bounds=(0.1, 30.0)):
        super().__init__(variances, length_scales, variances_bounds, length_scales_bounds)
        self.warping_a = warping_a
        self.warping_b = warping_b
        self.warping_bounds = warping_bounds

    # after the parent's length scales and variances in scikit-learn's (alphabetical) order
    @property
    def hyperparameter_warping_a(self) -> Hyperparameter:
        return Hyperparameter("warping_a", "numeric", self.warping_bounds, len(self.warping_a))

    @property
    def hyperparameter_warping_b(self) -> Hyperparameter:
        return Hyperparameter("warping_b", "numeric", self.warping_bounds, len(self.warping_b))

    def warp(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """w(X) and its derivatives in log a and log b, each the shape of ``X``."""
        a, b = np.asarray(self.warping_a, float), np.asarray(self.warping_b, float)
        x = np.clip(X, WARP_MARGIN, 1.0 - WARP_MARGIN)
        u = x ** a
        v = 1.0 - u
        vb = v ** b
        return 1.0 - vb, a * b * v ** (b - 1.0) * u * np.log(x), -b * vb * np.log(v)

    def _unwarped(self) -> AdditiveMatern:
        return AdditiveMatern(self.variances, self.length_scales, self.variances_bounds, self.length_scales_bounds)

    def __call__(self, X, Y=None, eval_gradient=False):
        X = np.atleast_2d(X)
        if not eval_gradient:
            return self._unwarped()(self.warp(X)[0], None if Y is None else self.warp(np.atleast_2d(Y))[0])
        if Y is not None:
            raise ValueError("the gradient is only defined for Y=None")
        w, dw_a, dw_b = self.warp(X)
        K, gradient = self._unwarped()(w, eval_gradient=True)
        # d k / d w_j(x) = s_j · m'(r) · sign(w_j(x) − w_j(y)) / l_j,  m'(r) = −(5/3) r (1 + √5 r) e^{−√5 r}
        lengths = np.asarray(self.length_scales, float)
        difference = w[:, None, :] - w[None, :, :]
        r = np.abs(difference) / lengths
        dk_dw = (-5.0 / 3.0) * r * (1.0 + SQRT5 * r) * np.exp(-SQRT5 * r) * np.asarray(self.variances, float)
        dk_dw *= np.sign(difference) / lengths
        return K, np.concatenate([gradient, dk_dw * (dw_a[:, None, :] - dw_a[None, :, :]),
                                  dk_dw * (dw_b[:, None, :] - dw_b[None, :, :])], axis=2)

    def __repr__(self) -> str:
        return (f"WarpedAdditiveMatern(variances={np.round(np.asarray(self.variances, float), 4).tolist()}, "
                f"length_scales={np.round(np.asarray(self.length_scales, float), 4).tolist()}, "
                f"warping_a={np.round(np.asarray(self.warping_a, float), 3).tolist()}, "
                f"warping_b={np.round(np.asarray(self.warping_b, float), 3).tolist()})")
