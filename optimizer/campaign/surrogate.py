"""Surrogate models of a campaign's expensive answers, fitted from its store.

One Gaussian-process regression per CFD objective and per CFD-derived constraint (scikit-learn's
:class:`~sklearn.gaussian_process.GaussianProcessRegressor`), fitted on the designs that gave values. Its
kernel (``algorithm.surrogate.kernel``) sums, weighed against each other by the marginal likelihood at
every fit:

* constant × Matérn 5/2 with one length scale per design variable: variables that act together;
* with ``kernel: additive`` only, the first-order additive Matérn 5/2
  (:class:`~optimizer.campaign.additive.AdditiveMatern`): a variance and a length scale per variable for
  effects of one variable at a time, which the product term learns only from designs near each other in
  every variable at once, and which it therefore misses in many variables with a few hundred designs;
* with ``kernel: warped`` instead, the same additive terms on each variable after a fitted monotone warping
  of its range (:class:`~optimizer.campaign.additive.WarpedAdditiveMatern`; its exponents under a
  log-normal prior of median 1, ``algorithm.surrogate.warp_prior_variance``): one-variable effects that
  are flat over most of a variable's range and steep in a corner of it;
* white noise, for the solver's scatter;

and a Gaussian-process classifier of **failure** — a design that does not give usable values
(failed mesh, diverged or unsettled solve, timeout) — fitted on every design that reached a worker.

Conventions:

* design vectors are scaled to the unit box by the problem's bounds before fitting, so length scales are
  shares of each variable's range;
* objectives are the minimised values (:attr:`EvaluationRow.minimised`), constraints G ≤ 0 feasible;
  both are standardised by the regressor (``normalize_y``), so predictions and standard deviations come
  back in the objective's own unit;
* the training set is capped (:attr:`SurrogateSettings.training`): a GP's fit costs O(n³), and the designs
  near the front are the ones the infill ranks, so the capped set is the ``training`` designs of best
  non-dominated rank (ties: the most recent), less the ``initial`` first designs stored and the ``recent``
  newest where the settings keep them. The classifier takes the ``training`` most recent designs.
* Fits are warm-started from the hyperparameters of the previous generation (stored with it, as JSON
  numbers — nothing is pickled), with a bounded number of optimiser iterations; the same store therefore
  gives the same models, on resume too. The models are fitted side by side, one thread each (up to the
  process's cores), which changes nothing in any of them.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from optimizer.campaign.config import KERNELS, SurrogateSettings

#: Iterations of the hyperparameter optimiser per fit (warm-started: a few suffice once the run settles).
FIT_ITERATIONS = 60
#: The schema's prior variance of the warping exponents (``algorithm.surrogate.warp_prior_variance``).
DEFAULT_WARP_PRIOR_VARIANCE = SurrogateSettings.model_fields["warp_prior_variance"].default


@dataclass(frozen=True)
class Prediction:
    """Model outputs for ``n`` designs: ``mean``/``std`` ``(n, m)`` of the minimised objectives,
    ``g_mean``/``g_std`` ``(n, k)`` of the modelled constraints, ``p_fail`` ``(n,)``."""

    mean: np.ndarray
    std: np.ndarray
    g_mean: np.ndarray
    g_std: np.ndarray
    p_fail: np.ndarray


@dataclass(frozen=True)
class TrainingData:
    """What the models learn from. X: ``(n, d)`` design vectors of every design that reached a worker;
    failed: ``(n,)`` bool; F: ``(n, m)`` minimised objectives, G: ``(n, k)`` modelled constraints (rows of
    failed designs are ignored); rank: ``(n,)`` non-dominated rank among the designs with values (failed:
    a large number); order: ``(n,)`` recency (larger is more recent)."""

    X: np.ndarray
    failed: np.ndarray
    F: np.ndarray
    G: np.ndarray
    rank: np.ndarray
    order: np.ndarray


def _cores() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _optimizer(iterations: int, prior: np.ndarray | None = None, variance: float = 1.0):
    """scikit-learn's ``optimizer`` callable: L-BFGS-B with a bounded number of iterations, maximising the
    marginal likelihood, or with ``prior`` (a mask of the log-hyperparameters that have one) the posterior
    under a normal prior of ``variance`` about 0 on those."""
    from scipy.optimize import minimize

    def run(objective, theta0, bounds):
        def posterior(theta):
            value, gradient = objective(theta)             # − log marginal likelihood and its gradient
            penalty = np.where(prior, theta, 0.0) / variance
            return value + 0.5 * float(np.dot(penalty, theta)), gradient + penalty

        result = minimize(objective if prior is None else posterior, theta0, method="L-BFGS-B", jac=True,
                          bounds=bounds, options={"maxiter": iterations})
        return result.x, result.fun

    return run


def _regressor(d: int, theta: Sequence[float] | None, kernel_name: str,
               warp_prior_variance: float = DEFAULT_WARP_PRIOR_VARIANCE):
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

    from optimizer.campaign.additive import AdditiveMatern, InPlaceSum, WarpedAdditiveMatern

    kernel = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(np.full(d, 0.5), (1e-3, 1e2), nu=2.5)
    if kernel_name == "additive":
        kernel = kernel + AdditiveMatern(np.full(d, 0.1), np.full(d, 0.3))
    elif kernel_name == "warped":
        kernel = kernel + WarpedAdditiveMatern(np.full(d, 0.1), np.full(d, 0.3), np.ones(d), np.ones(d))
    kernel = InPlaceSum(kernel, WhiteKernel(1e-4, (1e-8, 1e-1)))
    if theta is not None and len(theta) == len(kernel.theta):
        kernel = kernel.clone_with_theta(np.clip(np.asarray(theta, float), *kernel.bounds.T))
    # the warping exponents' prior: one per log-hyperparameter, in the kernel's order. Without it the two
    # exponents per variable, fitted to 200 designs, wander to their bounds (decision 0017)
    warping = np.concatenate([np.full(h.n_elements, "warping_" in h.name) for h in kernel.hyperparameters])
    prior = warping if warping.any() else None
    return GaussianProcessRegressor(kernel, normalize_y=True,
                                    optimizer=_optimizer(FIT_ITERATIONS, prior, warp_prior_variance))


def _training_set(data: TrainingData, cap: int, recent: int, initial: int) -> np.ndarray:
    """Indices of at most ``cap`` designs with values: the ``initial`` oldest, the ``recent`` newest, then
    the best-ranked of the rest (newest first among equals)."""
    chosen = np.flatnonzero(~data.failed)
    # a design the models misjudged ranks low and would never be learnt from once the store outgrows
    # the cap: the newest are kept whatever their rank
    by_age = chosen[np.argsort(data.order[chosen], kind="stable")]
    # the first designs (the initial population) are spread over the box: without them the best-ranked
    # crowd near the front, and the fitted length scales and warpings extrapolate the front's values into
    # the corners nobody has looked at since
    oldest = by_age[:min(initial, cap)]
    newest = by_age[len(oldest):][::-1][:min(recent, cap - len(oldest))]
    rest = np.setdiff1d(chosen, np.concatenate([oldest, newest]))
    rest = rest[np.lexsort((-data.order[rest], data.rank[rest]))][:cap - len(oldest) - len(newest)]
    return np.concatenate([oldest, newest, rest])


class _Conditioned:
    """A Gaussian process with hyperparameters fitted elsewhere, conditioned on ``X``, ``y``. Values are
    standardised by the mean and standard deviation of ``y_fitted``, the values the hyperparameters were
    fitted to, so that the fitted variances keep their meaning in the objective's unit."""

    def __init__(self, kernel, y_fitted: np.ndarray, X: np.ndarray, y: np.ndarray):
        from sklearn.gaussian_process import GaussianProcessRegressor

        self.kernel_ = kernel
        self._mean, self._scale = float(np.mean(y_fitted)), float(np.std(y_fitted)) or 1.0
        self.gp = GaussianProcessRegressor(kernel, optimizer=None).fit(X, (y - self._mean) / self._scale)

    def predict(self, X: np.ndarray, return_std: bool = False):
        mean, std = self.gp.predict(X, return_std=True)
        mean = mean * self._scale + self._mean
        return (mean, std * self._scale) if return_std else mean


class Models:
    """The fitted models of one generation (see the module docstring).

    lower, upper: the design box; labels: names of the modelled objectives and constraints (for the
    stored hyperparameters); kernel: ``product``, ``additive`` or ``warped`` (``algorithm.surrogate.kernel``, the
    module docstring); warp_prior_variance: with ``warped``, the variance of the normal prior on the log
    warping exponents (``algorithm.surrogate.warp_prior_variance``); theta (in :meth:`fit`):
    ``{label: log-hyperparameters}`` to warm-start from.
    """

    def __init__(self, lower: np.ndarray, upper: np.ndarray, objectives: Sequence[str], constraints: Sequence[str],
                 kernel: str = "product", warp_prior_variance: float = DEFAULT_WARP_PRIOR_VARIANCE):
        if kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}, not {kernel!r}")
        self.lower, self.upper = np.asarray(lower, float), np.asarray(upper, float)
        if not warp_prior_variance > 0:
            raise ValueError(f"warp_prior_variance must be above 0, not {warp_prior_variance!r}")
        self.kernel, self.warp_prior_variance = kernel, float(warp_prior_variance)
        self.objectives, self.constraints = tuple(objectives), tuple(constraints)
        self._regressors: dict[str, object] = {}
        self._classifier = None
        self._p_fail_constant = 0.0
        self.training_size = 0

    def scale(self, X: np.ndarray) -> np.ndarray:
        span = np.where(self.upper > self.lower, self.upper - self.lower, 1.0)
        return (np.asarray(X, float) - self.lower) / span

    # ------------------------------------------------------------------------------------------- fit
    def fit(self, data: TrainingData, cap: int, theta: dict[str, list[float]] | None = None,
            recent: int = 0, initial: int = 0, hyperparameter_initial: int = 0) -> Models:
        """Fit every model on ``data`` (at most ``cap`` designs each), warm-started from ``theta``: the
        ``initial`` oldest designs with values, the ``recent`` newest, then the best-ranked of the rest
        (newest first among equals). With ``hyperparameter_initial`` above 0, the hyperparameters are fitted
        on another set of ``cap`` designs, the ``hyperparameter_initial`` oldest and the best-ranked of the
        rest, and each model then predicts from the first set with them."""
        theta = theta or {}
        ok = ~data.failed
        if ok.sum() < 2:
            raise ValueError(f"the surrogate needs at least 2 designs with values, the store has {int(ok.sum())}")
        chosen = _training_set(data, cap, recent, initial)
        # the initial population shows how a response varies over the whole box (its length scales and
        # warpings); once the store outgrows the cap the best-ranked crowd near the front, where those are
        # not identifiable, and a fitted warping decays to the identity
        hyper = chosen
        if hyperparameter_initial:
            spread = _training_set(data, cap, 0, hyperparameter_initial)
            if not np.array_equal(np.sort(spread), np.sort(chosen)):   # the same designs: the usual fit
                hyper = spread
        X, X_hyper = self.scale(data.X[chosen]), self.scale(data.X[hyper])
        self.training_size = len(chosen)
        targets = [(label, data.F[:, i]) for i, label in enumerate(self.objectives)]
        targets += [(label, data.G[:, i]) for i, label in enumerate(self.constraints)]

        def regression(label: str, y: np.ndarray):
            fitted = _regressor(X.shape[1], theta.get(label), self.kernel, self.warp_prior_variance)
            fitted.fit(X_hyper, y[hyper])
            return fitted if hyper is chosen else _Conditioned(fitted.kernel_, y[hyper], X, y[chosen])

        # the models are independent, and each fit is deterministic on its own thread (one BLAS thread, its
        # own optimiser state), so they are fitted side by side on the cores the idle workers leave
        with warnings.catch_warnings(), ThreadPoolExecutor(min(len(targets) + 1, _cores())) as pool:
            warnings.simplefilter("ignore")        # convergence warnings of a bounded fit: expected
            fits = [(label, pool.submit(regression, label, y)) for label, y in targets]
            classifier = pool.submit(self._fit_classifier, data, cap, theta.get("failure"))
            self._regressors = {label: fit.result() for label, fit in fits}
            classifier.result()
        return self

    def _fit_classifier(self, data: TrainingData, cap: int, theta) -> None:
        recent = np.argsort(-data.order, kind="stable")[:cap]
        y = data.failed[recent]
        self._classifier = None
        if y.all() or not y.any():
            # one class only: the observed share, shrunk towards "unknown" by one pseudo-observation each way
            self._p_fail_constant = (y.sum() + 1.0) / (len(y) + 2.0) if y.any() else 0.0
            return
        from sklearn.gaussian_process import GaussianProcessClassifier
        from sklearn.gaussian_process.kernels import RBF, ConstantKernel

        kernel = ConstantKernel(1.0, (1e-2, 1e2)) * RBF(0.3, (1e-2, 1e1))
        if theta is not None and len(theta) == len(kernel.theta):
            kernel = kernel.clone_with_theta(np.clip(np.asarray(theta, float), *kernel.bounds.T))
        self._classifier = GaussianProcessClassifier(kernel, optimizer=_optimizer(FIT_ITERATIONS)).fit(
            self.scale(data.X[recent]), y.astype(int))

    def theta(self) -> dict[str, list[float]]:
        """The fitted log-hyperparameters per model (JSON numbers, stored with the generation)."""
        out = {label: [float(v) for v in m.kernel_.theta] for label, m in self._regressors.items()}
        if self._classifier is not None:
            out["failure"] = [float(v) for v in self._classifier.kernel_.theta]
        return out

    def gaussian_process(self, label: str):
        """The fitted scikit-learn regressor of objective or constraint ``label``, on the unit box of
        :meth:`scale`. Its kernel and Cholesky factor (``kernel_``, ``L_``) are in standardised values; its
        own ``predict`` may not be in the objective's unit (use :meth:`predict` for that), so compare
        ratios of its variances, not its values."""
        regressor = self._regressors[label]
        return regressor.gp if isinstance(regressor, _Conditioned) else regressor

    # --------------------------------------------------------------------------------------- predict
    def predict(self, X: np.ndarray) -> Prediction:
        X = self.scale(np.atleast_2d(X))
        n = len(X)
        if n == 0:
            empty = np.zeros((0, len(self.objectives))), np.zeros((0, len(self.constraints)))
            return Prediction(empty[0], empty[0], empty[1], empty[1], np.zeros(0))

        def stack(labels):
            if not labels:
                return np.zeros((n, 0)), np.zeros((n, 0))
            pairs = [self._regressors[label].predict(X, return_std=True) for label in labels]
            return np.column_stack([p[0] for p in pairs]), np.column_stack([p[1] for p in pairs])

        mean, std = stack(self.objectives)
        g_mean, g_std = stack(self.constraints)
        if self._classifier is None:
            p_fail = np.full(n, self._p_fail_constant)
        else:
            p_fail = self._classifier.predict_proba(X)[:, 1]
        return Prediction(mean, std, g_mean, g_std, p_fail)


class BatchConditioning:
    """The regressions' uncertainty over a pool of designs as the designs of one batch are chosen, each
    taken as observed at its predicted mean (the Kriging believer).

    With the hyperparameters fixed, a Gaussian process conditioned on an observation equal to its own
    prediction keeps its mean everywhere; only its covariance changes, by a rank-one update per design
    (Desautels, Krause & Burdick's GP-BUCB hallucination). So nothing is refitted: each chosen design
    adds one column of posterior covariance with the pool, and the pool's standard deviations shrink near
    it. The classifier of failure is not conditioned.

    models: fitted :class:`Models`; X: ``(n, d)`` the pool, problem units."""

    def __init__(self, models: Models, X: np.ndarray):
        from scipy.linalg import solve_triangular

        Xs = models.scale(np.atleast_2d(X))
        self._labels = (models.objectives, models.constraints)
        self._gps = {}
        for label in (*models.objectives, *models.constraints):
            gp = models.gaussian_process(label)
            V = solve_triangular(gp.L_, gp.kernel_(gp.X_train_, Xs), lower=True, check_finite=False)
            variance = np.maximum(gp.kernel_.diag(Xs) - np.einsum("ij,ij->j", V, V), 1e-300)
            # standardised units throughout: only the ratio of new to old variance leaves this class
            self._gps[label] = {"gp": gp, "V": V, "prior": variance, "now": variance.copy(), "columns": []}
        self._X = Xs

    def condition(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Take pool design ``i`` as observed at its predicted mean. Returns the factors ``(n, m)`` and
        ``(n, k)`` by which the objectives' and the constraints' standard deviations of the pool have shrunk
        since the first design (1: unchanged)."""
        for model in self._gps.values():
            gp, V = model["gp"], model["V"]
            # the latent covariance of every pool design with design i, less what earlier designs explain
            column = gp.kernel_(self._X, self._X[i:i + 1])[:, 0] - V.T @ V[:, i]
            for earlier in model["columns"]:
                column -= earlier * earlier[i]
            # the observation's variance: the latent variance at i plus the fitted noise (the kernel's diag)
            column /= np.sqrt(max(model["now"][i], 1e-300))
            model["columns"].append(column)
            model["now"] = np.maximum(model["now"] - column ** 2, 0.0)
        return tuple(self._ratio(labels) for labels in self._labels)

    def _ratio(self, labels) -> np.ndarray:
        if not labels:
            return np.ones((len(self._X), 0))
        return np.column_stack([np.sqrt(self._gps[k]["now"] / self._gps[k]["prior"]) for k in labels])
