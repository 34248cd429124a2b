"""Sequential design of an identification run to a target error (``rig acquire --target-nrmse``).

Instead of a fixed excitation, each next set-point is chosen from what is
known so far, and the run stops when the model's predicted held-out error
reaches the target.  Pure: no rig, no clock; the rig's side is
:mod:`rig.acquisition.adaptive`.

**The model's uncertainty.**  Equation (22) is linear in its parameters
``w`` (cell weights, bias, thermal term): a point measured at memory
state ``s`` (the row of signed areas, 1 and ``v``) reads ``s . w`` plus
noise of rms ``sigma``.  A Gaussian prior on ``w`` -- the cell weights
smooth over the Preisach plane (precision ``R / smooth_um^2``, ``R`` the
roughness of :mod:`identify.methods.triangle_penalty`) and of the size of
a cell of the reference device (``I / scale_um^2``); the bias and the
thermal term nearly free -- gives after the points ``S`` the posterior
covariance ``P = (Lambda + S^T S / sigma^2)^-1``, updated by one rank-one
step per point.

**Predicted held-out error.**  ``sqrt(mean_c s_c^T P s_c + sigma^2)`` over
the rows ``s_c`` of quasi-static random check runs on the grid, divided by
the span of the outputs measured so far: the nRMSE a check run is expected
to show.  ``sigma`` is checked against **replicate points** (a set-point
applied again at once: same memory state, so the two readings differ by
noise only): once :data:`MIN_REPLICATES` pairs exist their pooled rms
replaces the assumed noise if it is larger.

**Calibrated against the data.**  The prior is a guess; so every
:data:`CHECK_EVERY`-th point is a *check point*, a level drawn at random
(as a random check run draws them), whose reading is predicted before it is
used.  Once :data:`MIN_CHECKS` exist, the ratios of the squared errors of
the :data:`RECENT_CHECKS` latest to their predicted variances
(``s^T P s + sigma^2``), each capped at :data:`RATIO_CAP`, give the factor on
the predicted variance: their sum over the lower :data:`CONFIDENCE` quantile
of chi-squared with as many degrees of freedom -- the upper bound of the
factor at that confidence, had the model been calibrated.  A prior that was
too confident, or too cautious, is corrected by what the run showed, and
the run stops on a bound, not on a guess.

**The prediction the run stops on** is not the posterior's: the model a
user gets is :data:`HELD_OUT_METHOD`'s (smooth, non-negative), usually
better than the Gaussian posterior mean.  Every :data:`REFIT_EVERY` points,
once :data:`MIN_HELD_OUT` check points exist, that method is fitted on
every point but the check points (they still set the memory state), and
the upper :data:`CONFIDENCE` bound of its RMS error on the ``m`` check
points (``sqrt(sum e^2 / chi2_{1-CONFIDENCE}(m))``), over the span of the
outputs, is the predicted check nRMSE: a held-out estimate by the method
itself, on random levels as a check run draws them.  Before that, the
calibrated posterior's.

**The next point** (I-optimal): among the grid's walls and the midpoints
between them (off-wall points identify the thermal term) inside the window,
the one whose row ``s`` most reduces the mean predicted variance of the
check rows, ``|S_c P s|^2 / (sigma^2 + s^T P s)``; every
:data:`REPLICATE_EVERY`-th point is a replicate and every
:data:`CHECK_EVERY`-th a check point instead.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import IdentifyError
from .excitation import Excitation
from .fit import fit_sequence
from .grid import Grid
from .memory import CellStates, MemoryCurve
from .methods.triangle_penalty import dense_roughness_matrix
from .regressor import regressor_matrix

#: Every this many points, the next one repeats the last set-point (a replicate).
REPLICATE_EVERY = 25
#: Replicate pairs needed before their noise estimate is used.
MIN_REPLICATES = 3
#: Every this many points, the next one is a check point: a wall drawn at random, predicted before it is used.
CHECK_EVERY = 8
#: Check points needed before their errors calibrate the predicted variance, and how many recent ones do.
MIN_CHECKS, RECENT_CHECKS = 5, 24
#: A check point's squared error over its predicted variance counts at most this much (one wild point
#: must not decide the run).
RATIO_CAP = 10.0
#: The calibration is the upper bound of this one-sided confidence (the run stops on a bound, not a guess).
CONFIDENCE = 0.8
#: Every this many points the method the run's recipe names is refitted without the check points, and its
#: error on them becomes the prediction.
REFIT_EVERY = 20
#: Points before a target may end the run (the prediction needs some data behind it).
MIN_POINTS = 20
#: The method the prediction is about (the recipe ``rig acquire --target-nrmse`` records).
HELD_OUT_METHOD = "smooth_nn"
#: Check points needed before the held-out estimate replaces the posterior's (fewer give a noisy estimate
#: that a run stops on by chance: on the development devices, 5 check points let runs stop at 40 points
#: with a predicted 0.0008 against a measured 0.011).
MIN_HELD_OUT = 15
#: Prior standard deviation of the bias (um) and of the thermal term (um/V): nearly free.
FREE_SD = 1e3
#: Points of each random check run the predicted error is taken over, and how many runs.
CHECK_POINTS, CHECK_RUNS = 200, 4


class SequentialDesign:
    """The state of a sequential run on ``grid`` (see the module docstring).

    ``noise_um``: rms of one measured point (the average of its readings), um;
    ``scale_um``: prior sd of a cell weight (um); ``smooth_um``: prior sd of a
    difference of neighbouring cell weights (um); ``window``: the set-points
    allowed (V); ``thermal_term``: equation (22) with ``c_d v``.
    """

    def __init__(self, grid: Grid, *, noise_um: float, scale_um: float, smooth_um: float,
                 window: tuple[float, float] | None = None, thermal_term: bool = True, seed: int = 0) -> None:
        if not (noise_um > 0 and scale_um > 0 and smooth_um > 0):
            raise IdentifyError("noise, prior scale and smoothness must be positive")
        self.grid, self.thermal_term, self.noise_um = grid, thermal_term, float(noise_um)
        nc = grid.n_cells
        p = nc + 1 + int(thermal_term)
        lam = np.zeros((p, p))
        lam[:nc, :nc] = dense_roughness_matrix(grid) / smooth_um**2 + np.eye(nc) / scale_um**2
        lam[nc:, nc:] = np.eye(p - nc) / FREE_SD**2
        self.cov = np.linalg.inv(lam)
        self.mean = np.zeros(p)
        lo, hi = (grid.v_min, grid.v_max) if window is None else window
        walls = np.asarray(grid.walls, dtype=float)
        # the walls and the midpoints between them (off-wall points identify the thermal term)
        levels = np.sort(np.concatenate([walls, 0.5 * (walls[1:] + walls[:-1])]))
        self.candidates = levels[(levels >= lo - 1e-12) & (levels <= hi + 1e-12)]
        if self.candidates.size < 2:
            raise IdentifyError("the heater's window holds fewer than two walls of the grid")
        self.check = np.vstack([self._rows(Excitation.random(grid, CHECK_POINTS, seed + j).inputs)
                                for j in range(CHECK_RUNS)])
        #: The predicted variance of each check row (um^2), kept up to date by rank-one steps.
        self.check_var = np.einsum("ij,jk,ik->i", self.check, self.cov, self.check)
        self.states = CellStates(grid, MemoryCurve(grid.levels))
        self.inputs: list[float] = []
        self.outputs: list[float] = []
        self.pairs: list[float] = []
        self.errors: list[tuple[float, float]] = []  # check points: (squared error, predicted variance)
        self._rng = np.random.default_rng(seed)
        self._kinds: list[str] = []
        #: What :meth:`next_input` last proposed: "design", "check" or "replicate".
        self.proposed = "design"
        #: The latest held-out estimate (check nRMSE of :data:`HELD_OUT_METHOD` on the check points), or None.
        self.held_out: float | None = None

    # ------------------------------------------------------------ rows
    def _rows(self, v: np.ndarray) -> np.ndarray:
        return regressor_matrix(self.grid, v, self.thermal_term)

    def _row(self, areas: np.ndarray, v: float) -> np.ndarray:
        tail = [1.0, v] if self.thermal_term else [1.0]
        return np.concatenate([areas, tail])

    def _coordinate(self, v: float) -> float:
        return float(self.grid.coordinates(v))

    def row_if(self, v: float) -> np.ndarray:
        """The row a point at ``v`` (V) applied now would have (the memory is not moved)."""
        curve = self.states.curve.copy()
        curve.apply(self._coordinate(v))
        return self._row(curve.signed_areas(self.grid), v)

    # ------------------------------------------------------------ the design
    @property
    def sigma(self) -> float:
        """The noise of one point (um): assumed, or the replicates' when they show more."""
        if len(self.pairs) >= MIN_REPLICATES:
            return max(self.noise_um, float(np.sqrt(np.mean(np.square(self.pairs)) / 2.0)))
        return self.noise_um

    def next_input(self) -> float:
        """The set-point (V) to apply next: a replicate every :data:`REPLICATE_EVERY` points, else the
        I-optimal wall."""
        n = len(self.inputs)
        if n and n % REPLICATE_EVERY == 0:
            self.proposed = "replicate"
            return self.inputs[-1]
        if n % CHECK_EVERY == CHECK_EVERY - 1:
            self.proposed = "check"
            return float(self._rng.choice(self.candidates))
        self.proposed = "design"
        s2 = self.sigma**2
        best, gain = float(self.candidates[0]), -1.0
        for v in self.candidates:
            r = self.row_if(float(v))
            pr = self.cov @ r
            g = float(np.sum((self.check @ pr) ** 2)) / (s2 + float(r @ pr))
            if g > gain:
                best, gain = float(v), g
        return best

    def add(self, v: float, y: float, kind: str | None = None) -> None:
        """Point ``v`` (V) was applied and read ``y`` (um): move the memory, update the posterior.  ``kind``:
        what :meth:`next_input` proposed it as (default: its last proposal when ``v`` is that proposal)."""
        kind = kind or self.proposed
        self.proposed = "design"
        if kind == "replicate" and self.inputs and v == self.inputs[-1] and math.isfinite(y):
            self.pairs.append(y - self.outputs[-1])
        areas = self.states.apply(self._coordinate(v))
        r = self._row(areas.copy(), v)
        self.inputs.append(float(v))
        self.outputs.append(float(y))
        self._kinds.append(kind)
        if not math.isfinite(y):
            return
        s2 = self.sigma**2
        pr = self.cov @ r
        denom = s2 + float(r @ pr)
        if kind == "check":
            self.errors.append(((y - float(r @ self.mean)) ** 2, denom))
        if len(self.inputs) % REFIT_EVERY == 0 and len(self.errors) >= MIN_HELD_OUT:
            self.held_out = self._held_out()
        self.mean = self.mean + pr * (y - float(r @ self.mean)) / denom
        self.cov = self.cov - np.outer(pr, pr) / denom
        self.check_var = self.check_var - (self.check @ pr) ** 2 / denom

    def _held_out(self) -> float | None:
        """:data:`HELD_OUT_METHOD` fitted without the check points, its nRMSE on them; None if it cannot fit."""
        v, y = np.asarray(self.inputs), np.asarray(self.outputs)
        checks = (np.asarray(self._kinds) == "check") & np.isfinite(y)
        train = np.where(checks, np.nan, y)
        try:
            model = fit_sequence(self.grid, v, train, HELD_OUT_METHOD, thermal_term=self.thermal_term).model
        except IdentifyError:
            return None
        err = model.predict(v)[checks] - y[checks]
        span = float(np.ptp(y[np.isfinite(y)]))
        bound = math.sqrt(_upper_mean(err * err))  # the upper bound of the RMS
        return bound / span if span > 0 else None

    def predicted_nrmse(self) -> float:
        """The check nRMSE expected of the model now (see the module docstring); inf before two points."""
        if self.held_out is not None:
            return self.held_out
        y = np.asarray([o for o in self.outputs if math.isfinite(o)])
        if y.size < 2 or np.ptp(y) <= 0:
            return math.inf
        var = float(np.mean(self.check_var))
        return math.sqrt(self.calibration * var + self.sigma**2) / float(np.ptp(y))

    @property
    def calibration(self) -> float:
        """The factor the check points put on the predicted variance (1 until :data:`MIN_CHECKS`)."""
        if len(self.errors) < MIN_CHECKS:
            return 1.0
        e = np.asarray(self.errors[-RECENT_CHECKS:])
        return _upper_mean(np.minimum(e[:, 0] / e[:, 1], RATIO_CAP))

    def reached(self, target: float) -> bool:
        """Whether a run to ``target`` (check nRMSE) may end now: :data:`MIN_POINTS` points and
        :data:`MIN_CHECKS` check points behind a prediction at or below it."""
        return len(self.inputs) >= MIN_POINTS and len(self.errors) >= MIN_CHECKS \
            and self.predicted_nrmse() <= target

    def floor_nrmse(self, span_um: float) -> float:
        """The least check nRMSE any model can show on a device of output span ``span_um``: the noise."""
        return self.noise_um / span_um


def _upper_mean(squares: np.ndarray) -> float:
    """The upper :data:`CONFIDENCE` bound of the mean of ``m`` squared standard normals scaled by an unknown
    variance, from their values ``(m,)``: ``sum / chi2_{1 - CONFIDENCE}(m)``."""
    from scipy.stats import chi2  # here: importing identify does not pay for scipy.stats

    return float(np.sum(squares) / chi2.ppf(1.0 - CONFIDENCE, squares.size))
