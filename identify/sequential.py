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
from .settling import DWELL_STEP, REPLICATE_CODE, SETTLE_CHECKS, SETTLE_FACTOR, superseded, unsettled

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
#: Codes of each point's kind, as a session records them (``point_kind``).
KIND_CODES = {"design": 0, "check": 1, "replicate": REPLICATE_CODE}
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
    ``dwell_s`` (s): the first points' wait, lengthened as settle replicates
    demand (:mod:`identify.settling`) up to ``max_dwell_s``; None: the run's
    dwell is not the design's business (a fixed wait or a settle condition;
    replicates then only estimate the noise).
    """

    def __init__(self, grid: Grid, *, noise_um: float, scale_um: float, smooth_um: float,
                 window: tuple[float, float] | None = None, thermal_term: bool = True, seed: int = 0,
                 dwell_s: float | None = None, max_dwell_s: float = 600.0) -> None:
        if not (noise_um > 0 and scale_um > 0 and smooth_um > 0):
            raise IdentifyError("noise, prior scale and smoothness must be positive")
        if dwell_s is not None and not (0 < dwell_s <= max_dwell_s and math.isfinite(max_dwell_s)):
            raise IdentifyError(f"the dwell must be positive and at most {max_dwell_s:g} s, got {dwell_s}")
        self.grid, self.thermal_term, self.noise_um = grid, thermal_term, float(noise_um)
        nc = grid.n_cells
        p = nc + 1 + int(thermal_term)
        lam = np.zeros((p, p))
        lam[:nc, :nc] = dense_roughness_matrix(grid) / smooth_um**2 + np.eye(nc) / scale_um**2
        lam[nc:, nc:] = np.eye(p - nc) / FREE_SD**2
        self._prior_cov = np.linalg.inv(lam)
        self.cov = self._prior_cov.copy()
        self.mean = np.zeros(p)
        #: The run's dwell now (s), or None when the design does not set it.
        self.dwell_s = None if dwell_s is None else float(dwell_s)
        self.max_dwell_s = float(max_dwell_s)
        #: Each point's wait (s), as :meth:`add` was told (NaN: not told).
        self.waits: list[float] = []
        #: Settle-replicate differences (um) seen at the current dwell.
        self.settle_differences: list[float] = []
        #: How often the dwell was lengthened.
        self.lengthened = 0
        self._rows_seen: list[np.ndarray] = []
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
        self._prior_check_var = self.check_var.copy()
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

    @property
    def kept(self) -> np.ndarray:
        """Which points so far ``(n,)`` bool are measured and not superseded by a longer dwell."""
        y = np.asarray(self.outputs, dtype=float)
        out = np.isfinite(y)
        if self.dwell_s is not None and y.size:
            codes = np.asarray([KIND_CODES[k] for k in self._kinds])
            out &= ~superseded(np.asarray(self.waits), codes, self.dwell_s)
        return out

    def _wants_replicate(self, n: int) -> bool:
        if not n or self._kinds[-1] == "replicate":
            return False
        if n % REPLICATE_EVERY == 0:
            return True
        # a dwell not yet trusted: every design point is followed by a settle replicate
        return self.dwell_s is not None and len(self.settle_differences) < SETTLE_CHECKS \
            and self._kinds[-1] == "design" and math.isfinite(self.outputs[-1])

    def next_input(self) -> float:
        """The set-point (V) to apply next: a replicate every :data:`REPLICATE_EVERY` points (and, while the
        design sets the dwell, after each design point until :data:`~identify.settling.SETTLE_CHECKS`
        settle replicates stand at the current dwell), a check point every :data:`CHECK_EVERY`, else the
        I-optimal wall."""
        n = len(self.inputs)
        if self._wants_replicate(n):
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

    def next_dwell(self) -> float | None:
        """The wait (s) the point :meth:`next_input` last proposed asks for: a settle replicate
        :data:`~identify.settling.SETTLE_FACTOR` times the dwell, any other point the dwell; None when the
        design does not set the dwell."""
        if self.dwell_s is None:
            return None
        return self.dwell_s * (SETTLE_FACTOR if self.proposed == "replicate" else 1.0)

    def add(self, v: float, y: float, kind: str | None = None, waited_s: float | None = None) -> None:
        """Point ``v`` (V) was applied and read ``y`` (um) after waiting ``waited_s`` (s; default: what
        :meth:`next_dwell` asked): move the memory, update the posterior.  ``kind``: what
        :meth:`next_input` proposed it as (default: its last proposal).  A settle replicate that shows the
        points were not at rest lengthens the dwell and drops the points it supersedes."""
        kind = kind or self.proposed
        if waited_s is None:
            waited_s = self.next_dwell() if kind == self.proposed else None
        self.proposed = "design"
        replicate = kind == "replicate" and self.inputs and v == self.inputs[-1] and math.isfinite(y) \
            and math.isfinite(self.outputs[-1])
        difference = y - self.outputs[-1] if replicate else math.nan
        areas = self.states.apply(self._coordinate(v))
        r = self._row(areas.copy(), v)
        self.inputs.append(float(v))
        self.outputs.append(float(y))
        self._kinds.append(kind)
        self.waits.append(math.nan if waited_s is None else float(waited_s))
        self._rows_seen.append(r)
        if replicate and self.dwell_s is not None and self.kept[-2]:
            self.settle_differences.append(difference)
            if unsettled(np.asarray(self.settle_differences), self.noise_um) and self.dwell_s < self.max_dwell_s:
                self._lengthen()
                return
        if replicate:
            self.pairs.append(difference)
        if not math.isfinite(y):
            return
        self._update(len(self.inputs) - 1, refit=True)

    def _update(self, i: int, refit: bool) -> None:
        """The rank-one step of point ``i``."""
        r, y, kind = self._rows_seen[i], self.outputs[i], self._kinds[i]
        s2 = self.sigma**2
        pr = self.cov @ r
        denom = s2 + float(r @ pr)
        if kind == "check":
            self.errors.append(((y - float(r @ self.mean)) ** 2, denom))
        if refit and len(self.inputs) % REFIT_EVERY == 0 and len(self.errors) >= MIN_HELD_OUT:
            self.held_out = self._held_out()
        self.mean = self.mean + pr * (y - float(r @ self.mean)) / denom
        self.cov = self.cov - np.outer(pr, pr) / denom
        self.check_var = self.check_var - (self.check @ pr) ** 2 / denom

    def _lengthen(self) -> None:
        """The dwell was too short: lengthen it, and rebuild the posterior from the prior over the points
        the longer dwell keeps (in their order, as they came)."""
        self.dwell_s = min(self.dwell_s * DWELL_STEP, self.max_dwell_s)
        self.lengthened += 1
        self.settle_differences = []
        self.pairs = []  # their differences held the transient, not only noise
        self.cov, self.check_var = self._prior_cov.copy(), self._prior_check_var.copy()
        self.mean = np.zeros_like(self.mean)
        self.errors, self.held_out = [], None
        for i in np.flatnonzero(self.kept):
            self._update(int(i), refit=False)
        if len(self.errors) >= MIN_HELD_OUT:
            self.held_out = self._held_out()

    def _held_out(self) -> float | None:
        """:data:`HELD_OUT_METHOD` fitted without the check points, its nRMSE on them; None if it cannot fit."""
        v, y = np.asarray(self.inputs), np.asarray(self.outputs)
        kept = self.kept
        y = np.where(kept, y, np.nan)
        checks = (np.asarray(self._kinds) == "check") & kept
        train = np.where(checks, np.nan, y)
        try:
            model = fit_sequence(self.grid, v, train, HELD_OUT_METHOD, thermal_term=self.thermal_term).model
        except IdentifyError:
            return None
        err = model.predict(v)[checks] - y[checks]
        span = float(np.ptp(y[kept]))
        bound = math.sqrt(_upper_mean(err * err))  # the upper bound of the RMS
        return bound / span if span > 0 else None

    def predicted_nrmse(self) -> float:
        """The check nRMSE expected of the model now (see the module docstring); inf before two points."""
        if self.held_out is not None:
            return self.held_out
        y = np.asarray(self.outputs)[self.kept]
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
        """Whether a run to ``target`` (check nRMSE) may end now: :data:`MIN_POINTS` points kept,
        :data:`MIN_CHECKS` check points and the settle replicates the dwell needs behind a prediction at or
        below it."""
        if self.dwell_s is not None and len(self.settle_differences) < SETTLE_CHECKS \
                and self.dwell_s < self.max_dwell_s:
            return False
        return int(self.kept.sum()) >= MIN_POINTS and len(self.errors) >= MIN_CHECKS \
            and self.predicted_nrmse() <= target

    def floor_nrmse(self, span_um: float) -> float:
        """The least check nRMSE any model can show on a device of output span ``span_um``: the noise."""
        return self.noise_um / span_um


def _upper_mean(squares: np.ndarray) -> float:
    """The upper :data:`CONFIDENCE` bound of the mean of ``m`` squared standard normals scaled by an unknown
    variance, from their values ``(m,)``: ``sum / chi2_{1 - CONFIDENCE}(m)``."""
    from scipy.stats import chi2  # here: importing identify does not pay for scipy.stats

    return float(np.sum(squares) / chi2.ppf(1.0 - CONFIDENCE, squares.size))
