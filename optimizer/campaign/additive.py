"""The first-order additive Matérn 5/2 kernel: one one-dimensional Matérn 5/2 term per design variable,

    k(x, y) = Σ_j s_j · m(|x_j − y_j| / l_j),    m(r) = (1 + √5 r + 5r²/3) · exp(−√5 r),

with a variance ``s_j`` and a length scale ``l_j`` per variable (Duvenaud, Nickisch & Rasmussen, *Additive
Gaussian processes*, NeurIPS 2011, the first-order term). Summed with the usual product kernel (one length
scale per variable over all of them at once) it lets the marginal likelihood weigh a response made of
one-variable effects against one where the variables interact; scikit-learn has no kernel restricted to one
input column, hence this one, written to its :class:`~sklearn.gaussian_process.kernels.Kernel` interface
(log-hyperparameters, analytic gradient) so that its optimiser fits it like any other.
"""

from __future__ import annotations

import numpy as np
from sklearn.gaussian_process.kernels import Hyperparameter, Kernel, StationaryKernelMixin

SQRT5 = np.sqrt(5.0)


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
