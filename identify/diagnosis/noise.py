"""The noise floor: how small the check residual would be if the device had no unmodelled effect.

Two parts, added in squares at every check point ``n``::

    floor_n^2 = sigma_check^2 + sum_j (x_F pinv(X_F))_nj^2 sigma_j^2

the measurement noise of the check point itself, and the identification
noise that the base fit carries into its prediction (``j`` over the
identification points, see :mod:`identify.diagnosis.base`).

The measurement noise ``sigma`` is estimated, in this order of preference:

1. ``repeated_runs`` (used alone when available) -- two runs with the same inputs (a repeated check
   run): the difference of their outputs point by point cancels the
   device's response *and every deterministic effect* (lags, creep,
   nonlinearity act the same way twice); successive differences of it also
   remove slow drifts, which differ from run to run.
   ``sigma^2 = mean(diff(y1 - y2)^2) / 4``.
2. ``repeated_visits`` -- consecutive points of one run at the same
   set-point (the memory state is the same, only time passed):
   ``sigma^2 = mean((y_k - y_{k-1})^2) / 2``.  Effects that continue
   while the heater is held (creep, a slow lag, drift) add to it, so this
   is an upper bound.
   ``drift_monitor`` is the same estimate from a drift monitor's
   calibration points (a FORC measurement's: the same field after the same
   saturation before every curve, so the same memory state), second
   differences of successive ones (``sigma^2 = mean(d2^2) / 6``): a drift
   that is locally linear between three calibration points cancels; its
   curvature adds to it (an upper bound).
3. ``fit_residual`` -- the base fit's residual on the identification runs
   over its residual degrees of freedom (NNLS leaves cells at zero, so it
   is not interpolating): ``RSS / (m - rank X_F)``.  Effects the base
   model cannot absorb add to it; with few residual degrees of freedom
   (under :data:`MIN_FIT_DOF`) the free set's selection biases it low, and
   it is not used.

**A floor is measured, or it is only a bound.**  1 and 2 (and the drift
monitor) *measure* the noise: repeated readings of one memory state.  The
fit residual does not: it holds whatever the base model could not absorb
of the identification run -- the effect itself, often -- so it is never a
floor on its own (:attr:`NoiseEstimate.measured`).  Without a measured
floor the diagnosis uses :func:`fit_residual_bound`, an upper confidence
bound on the noise from the fit residual and its degrees of freedom: a
held-out error far above it is a gap; one within it is not "no gap" but
"cannot tell" (:mod:`~identify.diagnosis.verdict`).

Noise scales as ``1 / sqrt(K)`` with the number ``K`` of readings averaged
per measurement, which sessions record; estimates are converted between
runs that averaged differently.  Estimates 2 and 3 are pooled when they
agree (an F-test at 5 %); when they do not, the smaller is kept -- each
can only be inflated by an effect, so the larger is the contaminated one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import BaseFit
from .quantiles import chi2_ppf, f_ppf
from ..runs import Run

#: Fewest differences an estimate may rest on.
MIN_PAIRS = 8
#: Fewest residual degrees of freedom for the fit-residual estimate: NNLS chooses its free set to
#: fit the data, noise included, which biases a small residual low.
MIN_FIT_DOF = 50
#: Relative tolerance for "the same set-point".
SAME_INPUT = 1e-9
#: One-sided confidence of the upper bound on the noise from the fit residual (:func:`fit_residual_bound`).
BOUND_CONFIDENCE = 0.95
#: Sources that measure the noise (repeated readings of one memory state); the others only bound it.
MEASURED = ("repeated_runs", "repeated_visits", "drift_monitor")


@dataclass(frozen=True)
class NoiseEstimate:
    """Measurement noise: ``sigma_um`` rms per measurement averaged over ``readings`` readings
    (None: unknown, taken to be like every other run).  ``dof`` degrees of freedom of the
    estimate; ``source`` one of ``repeated_runs``, ``repeated_visits``, ``fit_residual``."""

    sigma_um: float
    readings: int | None
    source: str
    dof: float
    detail: str

    def sigma_for(self, readings: int | None) -> float:
        """The noise of a measurement averaging ``readings`` readings (um)."""
        if self.readings is None or readings is None:
            return self.sigma_um
        return self.sigma_um * float(np.sqrt(self.readings / readings))

    @property
    def measured(self) -> bool:
        """Whether the estimate rests on repeated readings of one memory state (a floor), not on a fit's
        residual alone (a bound: the residual holds what the model could not absorb)."""
        return any(part in MEASURED for part in self.source.split("+"))

    @property
    def relative_se_of_variance(self) -> float:
        """Standard error of ``sigma^2`` relative to it (chi-square with ``dof``)."""
        return float(np.sqrt(2.0 / max(self.dof, 1.0)))


def _same_inputs(a: Run, b: Run) -> bool:
    if a.n != b.n:
        return False
    scale = max(float(np.max(np.abs(a.inputs))), 1.0)
    return bool(np.allclose(a.inputs, b.inputs, rtol=0, atol=SAME_INPUT * scale))


def _readings(runs: list[Run]) -> int | None:
    ks = {r.readings for r in runs}
    return ks.pop() if len(ks) == 1 else None


def from_repeated_runs(runs: list[Run]) -> NoiseEstimate | None:
    """Pooled estimate from every pair of runs with identical inputs (consecutive in ``runs``)."""
    sq, count, pairs, used = 0.0, 0, 0, []
    for i, a in enumerate(runs):
        for b in runs[i + 1:]:
            if not _same_inputs(a, b) or a.readings != b.readings:
                continue
            both = np.isfinite(a.outputs) & np.isfinite(b.outputs)
            d = np.diff((a.outputs - b.outputs)[both])
            if d.size:
                sq += float(d @ d)
                count += d.size
                pairs += 1
                used += [a, b]
            break  # pair each run with its next repeat only
    if count < MIN_PAIRS:
        return None
    # successive differences overlap: about 2/3 of the points' information each
    return NoiseEstimate(float(np.sqrt(sq / count / 4.0)), _readings(used), "repeated_runs", count / 1.5,
                         f"{pairs} pair(s) of runs with identical inputs, {count} successive differences")


def from_repeated_visits(runs: list[Run]) -> NoiseEstimate | None:
    """Pooled estimate from consecutive measured points at the same set-point."""
    diffs, used = [], []
    for run in runs:
        y, v = run.outputs, run.inputs
        scale = max(float(np.max(np.abs(v))), 1.0)
        same = np.abs(np.diff(v)) <= SAME_INPUT * scale
        ok = same & np.isfinite(y[1:]) & np.isfinite(y[:-1])
        if ok.any():
            diffs.append((y[1:] - y[:-1])[ok])
            used.append(run)
    d = np.concatenate(diffs) if diffs else np.zeros(0)
    if d.size < MIN_PAIRS:
        return None
    return NoiseEstimate(float(np.sqrt(np.mean(d**2) / 2.0)), _readings(used), "repeated_visits", float(d.size),
                         f"{d.size} repeated set-points (an upper bound if the output moves while held)")


def from_monitor(monitors: list[np.ndarray]) -> NoiseEstimate | None:
    """Pooled estimate from drift monitors: each ``(k,)`` the outputs (um) of repeated measurements of
    one memory state, in time order.  Second differences (``mean(d2^2) / 6``): a drift that is linear over
    three successive calibration points cancels, so it does not pose as noise."""
    parts = []
    for m in monitors or []:
        y = np.asarray(m, dtype=float)
        y = y[np.isfinite(y)]
        if y.size >= 3:
            parts.append(np.diff(y, 2))
    d = np.concatenate(parts) if parts else np.zeros(0)
    if d.size < MIN_PAIRS:
        return None
    # second differences of white noise: variance 6 sigma^2, neighbours correlated (about half the information)
    return NoiseEstimate(float(np.sqrt(np.mean(d**2) / 6.0)), None, "drift_monitor", d.size / 2.0,
                         f"{d.size + 2 * len(parts)} calibration points, second differences (an upper bound: "
                         f"a drift's curvature between them adds)")


def from_fit_residual(base: BaseFit) -> NoiseEstimate | None:
    """Estimate from the base fit's residual on the identification runs."""
    if base.dof < MIN_FIT_DOF:
        return None
    r = base.measured - base.fitted
    return NoiseEstimate(float(np.sqrt(r @ r / base.dof)), _readings(list(base.fit_runs)), "fit_residual",
                         float(base.dof), f"base fit residual over {base.dof} residual degrees of freedom")


def fit_residual_bound(base: BaseFit, confidence: float = BOUND_CONFIDENCE) -> NoiseEstimate | None:
    """An upper confidence bound on the noise from the base fit's residual: ``RSS / chi2_(1-c)(dof)``.

    The residual holds the noise and whatever the base model could not absorb
    of the identification run, so the point estimate is not a floor; the bound
    says how large the noise could be (at ``confidence``, one-sided, the
    chi-square of the residual degrees of freedom), with any number of them.
    None without a residual degree of freedom.
    """
    if base.dof < 1:
        return None
    r = base.measured - base.fitted
    sigma = float(np.sqrt(r @ r / chi2_ppf(1.0 - confidence, base.dof)))
    return NoiseEstimate(sigma, _readings(list(base.fit_runs)), "fit_residual_bound", float(base.dof),
                         f"upper {100 * confidence:.0f} % bound from the base fit's residual over {base.dof} "
                         f"residual degrees of freedom (it holds whatever the model could not absorb)")


def _per_reading(e: NoiseEstimate) -> float:
    """Variance of one reading (or of one measurement when K is unknown)."""
    return e.sigma_um**2 * (e.readings or 1)


def combine(a: NoiseEstimate, b: NoiseEstimate) -> NoiseEstimate:
    """Pool two estimates that agree (F-test at 5 %); otherwise keep the smaller.

    Both kinds of estimate can only be inflated by an effect (never
    deflated), so when they disagree the larger one is the contaminated one.
    """
    if (a.readings is None) != (b.readings is None):
        return a if a.dof >= b.dof else b
    va, vb = _per_reading(a), _per_reading(b)
    ratio = va / vb
    lo, hi = f_ppf([0.025, 0.975], a.dof, b.dof)
    k = a.readings or 1
    if lo <= ratio <= hi:
        pooled = (a.dof * va + b.dof * vb) / (a.dof + b.dof)
        return NoiseEstimate(float(np.sqrt(pooled / k)), a.readings, f"{a.source}+{b.source}", a.dof + b.dof,
                             f"{a.detail}; and {b.detail}; pooled (they agree)")
    small, large = (a, b) if va < vb else (b, a)
    return NoiseEstimate(small.sigma_um, small.readings, small.source, small.dof,
                         f"{small.detail}; {large.source} gives {large.sigma_for(small.readings):.3g} um, "
                         f"significantly more (an effect inflates it), so it is not used")


def estimate_noise(base: BaseFit, check_runs: list[Run],
                   monitors: list[np.ndarray] | None = None) -> NoiseEstimate | None:
    """The best available estimate (see the module doc), or None.  ``monitors``: drift-monitor
    outputs (:func:`from_monitor`), counted as repeated visits."""
    runs = list(base.fit_runs) + list(check_runs)
    repeated = from_repeated_runs(runs)
    if repeated is not None:
        return repeated
    visits = from_repeated_visits(check_runs)
    monitor = from_monitor(monitors or [])
    if visits is not None and monitor is not None:
        visits = combine(visits, monitor)
    elif visits is None:
        visits = monitor
    found = [e for e in (from_fit_residual(base), visits) if e is not None]
    if len(found) == 2:
        return combine(*found)
    return found[0] if found else None


def floor_per_point(
    noise: NoiseEstimate, base: BaseFit, scored: list[tuple[Run, int]], carry: np.ndarray, extra: float = 0.0
) -> np.ndarray:
    """``floor_n`` (um) at the scored check points: own noise plus carried identification noise.

    ``scored`` lists each check run with its number of scored points, in
    the order of the rows of ``carry`` ``(m_check, m_fit)``, the carry-over
    of those points (identification points in the base fit's order) -- of
    the directions *not* re-estimated on the check data.  ``extra`` adds that
    fraction of the own noise variance (the re-estimated directions' fit).
    """
    fit_sigma = np.concatenate([np.full(r.rows.size, noise.sigma_for(r.readings)) for r in base.fit_runs])
    propagated = (carry**2) @ fit_sigma**2
    own = np.concatenate([np.full(int(k), noise.sigma_for(r.readings)) for r, k in scored])
    return np.sqrt(own**2 * (1.0 + extra) + propagated)
