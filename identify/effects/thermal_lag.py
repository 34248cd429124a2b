"""``thermal_lag``: the beam is measured short of its set-point, because part of its heating is slow.

The beam's temperature follows the heater through thermal dynamics of any
low order: a sum of first-order modes, mode ``j`` holding a fraction
``f_j`` of the temperature and relaxing with time constant ``tau_j`` over
each point's recorded dwell from where the previous point left it.  The
modes are a spectrum on :data:`TIME_CONSTANTS_S` (0.5 s to 30 min,
log-spaced: heat spreads into the chip, the package and the holder over
minutes to tens of minutes), so one, two or three modes -- or a continuum --
are all members.  Each mode's sign is set (settings ``sign`` and ``split_s``,
:data:`SIGNS`, :data:`SPLITS_S`): ``f_j >= 0`` is a beam short of its
set-point (a lag), ``f_j <= 0`` one beyond it (a lead: a heater whose
resistance rises with its temperature draws its power first and then less),
and a spectrum of one sign on its fast modes and the other on its slow ones
a step response that overshoots and comes back.  What drives them is a setting: the heater's
Joule **power** (the temperature rise is ``~ v^2``: heating and cooling
then lag differently) or the **voltage**::

    s_jk = d_k + (s_j,k-1 - d_k) exp(-dwell_k / tau_j),     d = v^2 (power) or v (voltage)
    x_k  = g(d_k + sum_j f_j (s_jk - d_k)),                 g = sqrt (power) or identity (voltage)

``x`` is what the memory curve sees (an equivalent heater voltage), and the
thermal term follows it too (the expansion follows the beam's
temperature).  An unknown dwell counts as fully settled.  Parameters:
``drive`` (``both``: the spectrum twice, once driven by each),
``time_constants_s``, ``fractions`` (in [-1, 1], each of its mode's sign,
fitted by projected Gauss--Newton steps on their secants: non-negative least
squares of the linearised problem in the signed columns), ``sign`` (+1 or -1)
and ``split_s`` (s, or None).

Option ``dominant`` (``--with thermal_lag:dominant``): the whole rise is
slow -- dwells as short as the time constant or shorter, as a plan within a
rig-time budget makes them (``rig acquire --rig-time``).  Gauss--Newton
steps from no lag cannot reach a lag that large, so the fit first scans the
dominant time constant: the whole rise in one mode, each drive, on a
log-spaced scan of :data:`SCAN_S` refined by Brent's method, each candidate
scored by the residual of the density solved with it; then it starts from
the whole rise in that mode, with the spectrum's other modes at fraction 0
beside it, and the usual steps shape the spectrum (a beam of several modes
is a mixture of them).

Identifiable only from a run whose dwells differ: with one dwell ``d`` a
mode enters only as ``f exp(-d / tau)``, so time constants and sizes
cannot be told apart -- and a model that cannot tell them apart cannot
predict a run with other dwells.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..grid import Grid
from ..runs import Run
from .base import INPUT, Columns, Context, Effect, finite_array, needs_dwell, needs_heater, single_columns

#: The modes' time constants (s): log-spaced from a fast beam to a slow package and holder.  Up to 5 min
#: until 2026-11-29: a lag mostly of 10-14 min paths on a tuning generator was then named an ambient drift (the room seems
#: to warm with the heating history), see docs/results/2026-11-29-gain-pivot-and-slow-lag.md.
TIME_CONSTANTS_S = tuple(float(x) for x in np.geomspace(0.5, 1800.0, 12))
#: What drives the modes (a setting): power, voltage, or both (a spectrum of each: a mixed drive).
DRIVES = ("power", "voltage", "both")
#: The modes' signs (a setting ``sign``, as creep's): ``+1`` the beam lags its set-point, ``-1`` it leads
#: (a step overshoots and relaxes back: a heater whose resistance rises with its temperature draws less
#: power as it warms, so a set-point's power arrives first and sags).
SIGNS = (1.0, -1.0)
#: Where the spectrum changes sign (a setting ``split_s``): its first slow time constant (s), or None for one
#: sign throughout.  ``sign`` on the faster modes and ``-sign`` on this one and the slower: a beam that lags
#: and then overshoots (a fast path that carries the rise, a slow one that gives part of it back), or the
#: reverse.  The 6th and the 9th of :data:`TIME_CONSTANTS_S` (20.7 s and 193 s).
SPLITS_S = (None, TIME_CONSTANTS_S[5], TIME_CONSTANTS_S[8])
#: Largest plausible lagging fraction of a mode (a whole rise arriving late).
MAX_FRACTION = 1.0
#: Step of the secant in a fraction: the columns are the derivative at the current fractions, not a secant
#: to a large lag.  Until 2026-11-29 it was 0.05; a lag just above the noise is a fraction of 0.002-0.003,
#: and a secant 20 times larger crosses cells of the memory curve that such a lag never reaches, so the
#: diagnosis's linearised lag closed 0.4-0.7 of a gap that the same family, fitted by ``rig identify
#: --with``, closes entirely (docs/results/2026-11-29-lag-derivative-and-first-rise.md).  A large lag is
#: still reached: the joint fit iterates, and the diagnosis linearises again at its fit.
STEP = 0.001
#: A mode whose whole fraction moves no run's hysteron input by this share of a cell is not fitted (see
#: :meth:`ThermalLag._visible`).
VISIBLE = 1e-3
#: Relative difference below which two dwells count as the same: a logger's overhead and timer jitter
#: make a "20 s" dwell read 20.0-20.4 s from time stamps (``rig import --dwell-from-time``).
SAME_DWELL = 0.05
#: Points whose dwell differs from the most common one needed before the lag is identifiable: a run of
#: one dwell with its first point different (dwells from time stamps) cannot tell sizes from time constants.
MIN_VARIED_DWELLS = 5
#: ``dominant``: the time constants (s) the scan tries before refining the best.
SCAN_S = tuple(float(x) for x in np.geomspace(0.1, 100.0, 13))
#: ``dominant``: a mode of the spectrum within this log-distance of the scanned one is left out of the start.
SAME_MODE = 0.2
#: ``dominant``: Brent's tolerance on log(time constant).
SCAN_TOL = 0.01


def _drive(v: np.ndarray, drive: str) -> np.ndarray:
    return v * v if drive == "power" else v


def slow_mode(run: Run, tau: float, v: np.ndarray | None = None, drive: str = "power") -> np.ndarray:
    """One mode's state after each point's dwell, ``(n,)`` (V^2 for power, V for voltage); ``v`` defaults
    to the run's inputs."""
    v = run.inputs if v is None else v
    d = np.where(np.isfinite(run.dwell_s), run.dwell_s, np.inf)
    keep = np.exp(-np.clip(d, 0.0, None) / tau)
    target = _drive(v, drive)
    out = np.empty(run.n)
    prev = float(_drive(np.asarray(run.initial_V), drive))
    for k in range(run.n):
        prev = target[k] + (prev - target[k]) * keep[k]
        out[k] = prev
    return out


def lagged(run: Run, tau: float | np.ndarray, fraction: float | np.ndarray, v: np.ndarray | None = None,
           drive: str = "power") -> np.ndarray:
    """The lagged input (V), ``(n,)``, signed as ``v``: modes ``tau`` (s) with ``fraction`` each.  With
    ``drive="both"`` the modes are :func:`mode_drives`: the power-driven ones lag the equivalent voltage
    through the power, the voltage-driven ones then add their lag in volts."""
    v = run.inputs if v is None else v
    taus, fractions = np.atleast_1d(tau), np.atleast_1d(fraction)
    drives = mode_drives(drive, taus.size)
    out = v
    for which in ("power", "voltage"):
        mine = [(t, f) for t, f, d in zip(taus, fractions, drives) if d == which and f]
        if not mine:
            continue
        target = _drive(v, which)
        lag = np.zeros(run.n)
        for t, f in mine:
            lag += f * (slow_mode(run, float(t), v, which) - target)
        if which == "power":
            # signed as v, a set-point of 0 V as a positive one: the beam heated before it is still warm
            out = np.where(v < 0, -1.0, 1.0) * np.sqrt(np.maximum(target + lag, 0.0))
        else:
            out = out + lag
    return out


def signs_of(setting: dict[str, Any], taus: np.ndarray) -> np.ndarray:
    """``(modes,)``: the sign of each mode of time constants ``taus`` (s) in a setting or fitted params:
    ``sign`` (default +1), flipped for the modes at ``split_s`` and slower."""
    signs = np.full(np.size(taus), float(setting.get("sign", 1.0)))
    if setting.get("split_s") is not None:
        signs[np.asarray(taus) >= float(setting["split_s"]) * (1.0 - 1e-9)] *= -1.0
    return signs


def mode_drives(drive: str, n: int) -> list[str]:
    """What drives each of ``n`` modes: all ``drive``, or for ``both`` the first half power, the rest voltage."""
    if drive == "both":
        return ["power"] * (n // 2) + ["voltage"] * (n - n // 2)
    return [drive] * n


class ThermalLag(Effect):
    name = "thermal_lag"
    summary = "the dwell is too short for the thermal dynamics: the beam is measured short of its set-point"
    stage = INPUT
    drives_thermal_term = True
    options = ("dominant",)
    absolute = True
    must_record = (needs_heater, needs_dwell)
    inversion = "lag"

    def __init__(self, params: dict[str, Any] | None = None, *, dominant: bool = False) -> None:
        super().__init__(params)
        self.dominant = bool(dominant)

    def scan(self, score):
        """(``dominant``) The start of the fit: see the module docstring; None without the option."""
        if not self.dominant or self.fitted:
            return None
        from scipy.optimize import minimize_scalar  # here: rig identify's start-up does not pay for scipy.optimize
        best: tuple[float, str, float] | None = None
        for drive in ("power", "voltage"):
            cache: dict[float, float] = {}

            def rss(log_tau: float, drive: str = drive) -> float:
                if log_tau not in cache:
                    cache[log_tau] = score(ThermalLag({"drive": drive, "time_constants_s": [math.exp(log_tau)],
                                                       "fractions": [1.0]}))
                return cache[log_tau]

            logs = [math.log(t) for t in SCAN_S]
            values = [rss(g) for g in logs]
            i = int(np.argmin(values))
            lo, hi = logs[max(i - 1, 0)], logs[min(i + 1, len(logs) - 1)]
            minimize_scalar(rss, bounds=(lo, hi), method="bounded", options={"xatol": SCAN_TOL})
            g = min(cache, key=cache.get)
            if best is None or cache[g] < best[0]:
                best = (cache[g], drive, math.exp(g))
        _, drive, tau = best
        taus = sorted([t for t in TIME_CONSTANTS_S if abs(math.log(t / tau)) > SAME_MODE] + [tau])
        return ThermalLag({"drive": drive, "time_constants_s": taus,
                           "fractions": [1.0 if t == tau else 0.0 for t in taus]})

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        if "time_constant_s" in params:  # one mode, as written by hand
            params = {"drive": params.get("drive", "power"), "time_constants_s": [params["time_constant_s"]],
                      "fractions": [params["fraction"]]}
        taus = finite_array(params, "time_constants_s", self.name)
        fractions = finite_array(params, "fractions", self.name)
        drive = params.get("drive", "power")
        if taus.size == 0 or taus.size != fractions.size or np.any(taus <= 0) or drive not in DRIVES:
            raise IdentifyError(f"effect {self.name!r}: time_constants_s (> 0) and fractions must match, drive one of "
                                f"{', '.join(DRIVES)}")
        sign, split = params.get("sign"), params.get("split_s")
        if sign is None:  # written without: the signs the fractions have (a lead if none is positive)
            sign = -1.0 if np.any(fractions < 0) and not np.any(fractions > 0) else 1.0
        if float(sign) not in SIGNS or (split is not None and not (math.isfinite(float(split)) and float(split) > 0)):
            raise IdentifyError(f"effect {self.name!r}: sign must be 1 or -1 and split_s a time constant (s) > 0")
        return {"drive": drive, "time_constants_s": taus.tolist(), "fractions": fractions.tolist(),
                "sign": float(sign), "split_s": None if split is None else float(split)}

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        why = self.applicable(runs)
        if why is not None:
            return why
        dwells = np.concatenate([r.dwell_s[r.rows] for r in runs])
        dwells = dwells[np.isfinite(dwells)]
        common = float(np.median(dwells)) if dwells.size else math.nan
        others = int(np.sum(np.abs(dwells - common) > SAME_DWELL * abs(common)))  # 0 with no dwell at all
        if others < MIN_VARIED_DWELLS:
            d = f" ({common:.3g} s)" if dwells.size else ""
            but = f" but {others}" if others else ""
            return (f"every measured point{but} has the same dwell{d}, so the lag's time constants and sizes "
                    "cannot be told apart; record the identification run with varied dwells "
                    "(rig acquire --sequence damped --dwells 8,15,30,60)")
        return None

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"drive": d, "sign": s, **({} if k is None else {"split_s": k})}
                for d in DRIVES for s in SIGNS for k in SPLITS_S]

    def fit_settings_grid(self) -> list[dict[str, float]]:
        if self.fitted:  # a start found by the scan (``dominant``): its own drive and signs
            p = self.params
            return [{"drive": p["drive"], "sign": p["sign"], **({} if p["split_s"] is None else {"split_s": p["split_s"]})}]
        return self.settings_grid()

    def _state(self, setting: dict[str, float]) -> tuple[str, np.ndarray, np.ndarray]:
        if self.fitted:
            p = self.params
            return p["drive"], np.asarray(p["time_constants_s"]), np.asarray(p["fractions"])
        drive = setting.get("drive", "power")
        taus = np.asarray(TIME_CONSTANTS_S * (2 if drive == "both" else 1))
        return drive, taus, np.zeros(taus.size)

    def modes(self) -> tuple[np.ndarray, np.ndarray, list[str]]:
        drive, taus, fractions = self._state({})
        return taus.astype(float), fractions.astype(float), mode_drives(drive, taus.size)

    def transform(self, run: Run, x: np.ndarray, feedback: np.ndarray | None = None) -> np.ndarray:
        drive, taus, fractions = self._state({})
        if not np.any(fractions):
            return x
        return lagged(run, taus, fractions, x, drive)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        """The secant of the output in each mode's fraction (at the current fractions; the memory curve and
        the thermal term both see the lagged input); zero for a mode no run can see (:meth:`_visible`)."""
        drive, taus, f0 = self._state(setting)
        values = self._unsigned(ctx, drive, taus, f0)
        labels = tuple(f"{d}_fraction_at_{t:.3g}s" if drive == "both" else f"fraction_at_{t:.3g}s"
                       for t, d in zip(taus, mode_drives(drive, taus.size)))
        signs = signs_of(self.params if self.fitted else setting, taus)  # a fitted lag keeps its signs
        return single_columns(ctx.runs, [v * signs for v in values], labels, (True,) * taus.size)

    def _unsigned(self, ctx: Context, drive: str, taus: np.ndarray, f0: np.ndarray) -> list[np.ndarray]:
        """Each run's secants ``(n, modes)`` in each mode's fraction at ``f0``; at no lag computed once per
        context and drive for all the settings of signs (the last context's kept)."""
        key = (drive, tuple(taus), tuple(f0))
        memo = getattr(self, "_memo", None)
        if memo is not None and memo[0] is ctx and memo[1] == key:
            return memo[2]
        heres = [lagged(run, taus, f0, drive=drive) for run in ctx.runs]
        seen = self._visible(ctx, drive, taus, f0, heres)
        values = []
        for i, (run, here) in enumerate(zip(ctx.runs, heres)):
            base = ctx.response(i, here, here)
            cols = np.zeros((run.n, taus.size))
            for j in np.flatnonzero(seen):
                f = f0.copy()
                f[j] += STEP
                moved = lagged(run, taus, f, drive=drive)
                cols[:, j] = (ctx.response(i, moved, moved) - base) / STEP
            values.append(cols)
        self._memo = (ctx, key, values)
        return values

    @staticmethod
    def _visible(ctx: Context, drive: str, taus: np.ndarray, f0: np.ndarray, heres: list[np.ndarray]) -> np.ndarray:
        """``(modes,)`` bool: whether the whole of a mode (its fraction from 0 to :data:`MAX_FRACTION`, the
        others as in ``f0``) moves the hysterons' input of some run by :data:`VISIBLE` of a cell; ``heres``
        each run's lagged input at ``f0``.  A mode much faster than every dwell has settled at every
        reading: its column is zero but for rounding, and a fit would give it any fraction (a rival for a
        plan with short dwells that the data never asked for)."""
        seen = np.zeros(taus.size, dtype=bool)
        for run, here in zip(ctx.runs, heres):
            for j in np.flatnonzero(~seen):
                none, whole = f0.copy(), f0.copy()
                none[j], whole[j] = 0.0, MAX_FRACTION
                without = here if f0[j] == 0 else lagged(run, taus, none, drive=drive)
                seen[j] = np.max(np.abs(lagged(run, taus, whole, drive=drive) - without)) > VISIBLE * ctx.grid.step
        return seen

    def coefficients(self, ctx: Context) -> np.ndarray:
        """The fractions in the columns' signs (each mode's fraction times its sign: >= 0 when fitted)."""
        p = self.params
        return np.asarray(p["fractions"], dtype=float) * signs_of(p, np.asarray(p["time_constants_s"]))

    def with_fit(self, ctx, setting, coef, cols) -> "ThermalLag":
        drive, taus, _ = self._state(setting)
        source = self.params if self.fitted else setting  # a fitted lag keeps its signs
        sizes = np.clip(np.asarray(coef, dtype=float), 0.0, MAX_FRACTION)  # none to the whole rise, each its sign
        return ThermalLag({"drive": drive, "time_constants_s": taus.tolist(),
                           "fractions": (signs_of(source, taus) * sizes).tolist(),
                           "sign": float(source.get("sign", 1.0)), "split_s": source.get("split_s")})

    def bounds(self) -> dict[str, float]:
        out = {f"fraction_at_{t:.3g}s": MAX_FRACTION for t in TIME_CONSTANTS_S}
        out.update({f"{d}_fraction_at_{t:.3g}s": MAX_FRACTION for t in TIME_CONSTANTS_S for d in ("power", "voltage")})
        return out

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        p = self.params
        f = np.asarray(p["fractions"])
        taus = np.asarray(p["time_constants_s"])
        total = float(f.sum())
        size = float(np.abs(f).sum())
        return {"drive": p["drive"], "sign": p["sign"], "split_s": p["split_s"], "fraction": total,
                "mean_time_constant_s": float(np.sum(np.abs(f) * taus) / size) if size > 0 else None,
                "modes": {f"at_{t:.3g}s": float(x) for t, x in zip(taus, f) if x != 0}}
