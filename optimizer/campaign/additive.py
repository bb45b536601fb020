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

:class:`InPlaceSum` is the sum of a surrogate's kernel terms, computing their gradients in one array.
"""

from __future__ import annotations

import numpy as np
from sklearn.gaussian_process.kernels import Hyperparameter, Kernel, StationaryKernelMixin, Sum

SQRT5 = np.sqrt(5.0)
#: How far inside the unit interval the warping clips its inputs (log x and log(1 − x^a) stay finite).
WARP_MARGIN = 1e-9


def _fill_gradient(Z: np.ndarray, variances: np.ndarray, lengths: np.ndarray,
                   gradient: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The additive kernel of the rows of ``Z`` ``(n, d)`` with themselves, ``K`` ``(n, n)``, with its derivatives
    in the log length scales and log variances written to ``gradient[:, :, :d]`` and ``gradient[:, :, d:2d]``;
    also returns d k(z, z') / d z_j, ``(d, n, n)``, for a kernel of transformed inputs to chain.

    At a campaign's 200 designs these arrays are most of a fit's cost, so each is computed once, in place,
    variable by variable: ``gradient`` is a view of a variable-major array (:func:`gradient_array`), so that
    each variable's (n, n) plane is contiguous."""
    d = Z.shape[1]
    planes = gradient.transpose(2, 0, 1)                   # (2d, n, n), contiguous planes
    s, lengths = variances[:, None, None], lengths[:, None, None]
    difference = Z.T[:, :, None] - Z.T[:, None, :]         # (d, n, n)
    r = np.abs(difference)
    r /= lengths
    e = np.multiply(-SQRT5, r)
    np.exp(e, out=e)                                       # e^{−√5 r}
    q = np.multiply(SQRT5, r)
    q += 1.0
    q *= e                                                 # (1 + √5 r) e^{−√5 r}
    np.multiply(r, r, out=r)                               # r² from here on
    np.multiply(r, e, out=e)
    e *= 5.0 / 3.0
    e += q                                                 # m(r) = (1 + √5 r + 5r²/3) e^{−√5 r}
    K = np.tensordot(variances, e, axes=1)
    np.multiply(e, s, out=planes[d:2 * d])                 # d k / d log s_j = s_j m
    r *= q
    np.multiply(r, s * (5.0 / 3.0), out=planes[:d])       # d k / d log l_j = s_j (5/3) r² (1 + √5 r) e^{−√5 r}
    # d k / d z_j = s_j m'(r) sign(z_j − z'_j) / l_j = −(5/3) (s_j / l_j²) (z_j − z'_j) (1 + √5 r) e^{−√5 r}
    difference *= q
    difference *= (-5.0 / 3.0) * s / lengths**2
    return K, difference


def gradient_array(n: int, n_dims: int) -> np.ndarray:
    """An ``(n, n, n_dims)`` gradient array stored hyperparameter-major, so that the additive terms' planes
    are contiguous; scikit-learn reads it through its strides."""
    return np.empty((n_dims, n, n)).transpose(1, 2, 0)


#: Elements of the ``(rows, m, d)`` temporaries of one block of ``k(X, Y)`` (256 kB of doubles).
BLOCK = 32768


def _matern_sum(X: np.ndarray, Y: np.ndarray, s: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """``Σ_j s_j m(|x_j − y_j| / l_j)`` for every pair of rows of ``X`` and ``Y``: ``(n, m)``."""
    # computed in place, in the order of the formulas' terms, so that the values are those of the plain
    # expressions, bit for bit
    r = X[:, None, :] - Y[None, :, :]
    np.abs(r, out=r)
    r /= lengths
    e = np.multiply(-SQRT5, r)
    np.exp(e, out=e)                                   # e^{−√5 r}
    m = np.multiply(SQRT5, r)
    m += 1.0
    t = np.multiply(5.0 / 3.0, r)
    t *= r
    m += t
    m *= e                                             # (1 + √5 r + 5r²/3) e^{−√5 r}
    return m @ s


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
        if not eval_gradient:
            return self._value(X, X if Y is None else np.atleast_2d(Y))
        if Y is not None:
            raise ValueError("the gradient is only defined for Y=None")
        gradient = gradient_array(len(X), self.n_dims)
        return self.fill_gradient(X, gradient), gradient

    def fill_gradient(self, X: np.ndarray, gradient: np.ndarray) -> np.ndarray:
        """k(X, X), its gradient in the log-hyperparameters written to ``gradient`` ``(n, n, n_dims)``."""
        return _fill_gradient(X, np.asarray(self.variances, float), np.asarray(self.length_scales, float),
                              gradient)[0]

    def _value(self, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        s, lengths = np.asarray(self.variances, float), np.asarray(self.length_scales, float)
        # a block of rows at a time, so that the (rows, m, d) temporaries stay in cache: a pool of 1 000
        # designs against 200 in 13 variables is 1.7 times faster so, each row's values the same
        rows = max(1, BLOCK // max(1, Y.shape[0] * Y.shape[1]))
        K = np.empty((len(X), len(Y)))
        for start in range(0, len(X), rows):
            K[start:start + rows] = _matern_sum(X[start:start + rows], Y, s, lengths)
        return K

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
        gradient = gradient_array(len(X), self.n_dims)
        return self.fill_gradient(X, gradient), gradient

    def fill_gradient(self, X: np.ndarray, gradient: np.ndarray) -> np.ndarray:
        w, dw_a, dw_b = self.warp(X)
        d = w.shape[1]
        K, dk_dw = _fill_gradient(w, np.asarray(self.variances, float), np.asarray(self.length_scales, float),
                                  gradient)
        # chain rule: d k / d log a_j = d k / d w_j(x) · (d w_j(x) / d log a_j − d w_j(y) / d log a_j), b alike
        planes = gradient.transpose(2, 0, 1)
        for block, dw in ((planes[2 * d:3 * d], dw_a.T), (planes[3 * d:], dw_b.T)):
            np.subtract(dw[:, :, None], dw[:, None, :], out=block)
            block *= dk_dw
        return K

    def __repr__(self) -> str:
        return (f"WarpedAdditiveMatern(variances={np.round(np.asarray(self.variances, float), 4).tolist()}, "
                f"length_scales={np.round(np.asarray(self.length_scales, float), 4).tolist()}, "
                f"warping_a={np.round(np.asarray(self.warping_a, float), 3).tolist()}, "
                f"warping_b={np.round(np.asarray(self.warping_b, float), 3).tolist()})")


class InPlaceSum(Sum):
    """scikit-learn's :class:`~sklearn.gaussian_process.kernels.Sum`, its gradient written into one array.

    scikit-learn stacks a sum's gradient level by level (``np.dstack``), copying every term's (n, n, p)
    block once per level above it, in an (n, n, p) layout where each hyperparameter's plane is strided. Here
    each term writes its block in place (:func:`fill_gradient`) into a hyperparameter-major array
    (:func:`gradient_array`): the values are the same sums, in the same order, and a fit, which evaluates
    the gradient some 60 times, takes about half the time with the warped terms
    (``python bench/bench_kernel.py``)."""

    def __call__(self, X, Y=None, eval_gradient=False):
        if not eval_gradient:
            return super().__call__(X, Y)
        if Y is not None:
            raise ValueError("the gradient is only defined for Y=None")
        X = np.atleast_2d(X)
        gradient = gradient_array(len(X), self.n_dims)
        return fill_gradient(self, X, gradient), gradient


def fill_gradient(kernel: Kernel, X: np.ndarray, gradient: np.ndarray) -> np.ndarray:
    """``kernel(X)``, its gradient in the log-hyperparameters written to ``gradient`` ``(n, n, n_dims)``:
    sums term by term into their blocks, the additive terms in place, any other kernel by a copy."""
    if isinstance(kernel, Sum):
        split = kernel.k1.n_dims
        K = fill_gradient(kernel.k1, X, gradient[:, :, :split])
        return K + fill_gradient(kernel.k2, X, gradient[:, :, split:])
    if isinstance(kernel, AdditiveMatern):
        return kernel.fill_gradient(X, gradient)
    K, gradient[...] = kernel(X, eval_gradient=True)
    return K
