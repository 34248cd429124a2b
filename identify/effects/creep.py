"""``creep``: the deflection relaxes slowly after the output changes.

A change of the output relaxes afterwards (um), and relaxations add up
(Boltzmann superposition).  What drives it is a setting:

* ``reversal`` -- each excursion of the input ``E_r`` (V) that ends at a
  reversal, from the time ``t_r`` the input turned back: ``E_r K(t - t_r)``;
* ``output`` -- every change of the hysteresis part's output ``du_k`` (um)
  at every set-point, from the time it was applied: ``du_k K(t - t_k)``
  (the first change from the output at the run's initial state: negative
  saturation at ``initial_V``, where the sequencer starts every run);
* ``phase`` -- the same for the phase transition's part alone (the
  Preisach sum, without the bias and the thermal term);
* ``excursion`` -- every change ``dE_k`` of the output's excursion since
  the output last turned back (it starts afresh at each turn), from the
  time it was applied: ``dE_k K(t - t_k)``.  Only the part that relaxes
  away is a column: the settled creep of a creep that moves towards the
  size of the current excursion (``E(t)`` times the weight, which the base
  fit does not absorb) was tried as a column and taken back -- it then
  followed a slow drift of the check run when the drift was not a
  candidate (see the README, *Where it still fails*);
* ``phase_excursion`` -- the same for the phase transition's part alone
  (it turns back with the input; the whole output can turn where the
  thermal term outweighs the transition).

The kernel is a relaxation spectrum, ``K(t) = s sum_j a_j exp(-t / tau_j)``
with ``a_j >= 0`` over :data:`TIME_CONSTANTS_S` (2 s to 5.5 h, log-spaced)
and one sign ``s`` (a setting) -- or two branches (the setting ``split``,
:data:`SPLITS`): ``s`` on the fast time constants, ``-s`` on the slow ones,
a creep that moves one way and then relaxes back (a fast viscous part and
a slower one of the other sign, as in a bimorph whose layers relax at
their own rates).  With one sign it decays monotonically whatever its shape
-- a single exponential, a stretched exponential, a power law, logarithmic
creep over the spectrum's span (any completely monotone kernel is such a
mixture), or logarithmic and Andrade creep that keep growing over the
run (their growth over hours is a sum of long relaxations).  A roughness penalty on the spectrum over ``log tau`` (its
weight a setting, chosen by cross-validation in the diagnosis) keeps the
family from paying for its flexibility with noise.  Each relaxation is
summed recursively (one pass per time constant), so long runs cost
``O(n)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..grid import Grid
from ..runs import Run
from .base import OUTPUT, Columns, Context, Effect, finite_array, needs_reversals, needs_time, start_of

#: A change of the driving output smaller than this fraction of its range does not turn it back (``excursion``).
STILL = 1e-9
#: Relaxation times of the kernel (s): log-spaced from 2 s to 5.5 h.
TIME_CONSTANTS_S = tuple(float(x) for x in np.geomspace(2.0, 20000.0, 9))
#: Where a two-branch kernel changes sign (a setting): the index of its first slow time constant, or None
#: for one sign throughout.  A creep that lags and then relaxes back (or overshoots and recovers) is a fast
#: branch of one sign and a slow one of the other.
SPLITS = (None, 3, 5)
#: What drives the relaxation (a setting).
DRIVES = ("reversal", "output", "phase", "excursion", "phase_excursion")
#: The drives that follow the phase-transition part of the output (without the bias and the thermal term).
PHASE_DRIVES = ("phase", "phase_excursion")
#: The drives that follow an excursion since the driving output last turned back.
EXCURSION_DRIVES = ("excursion", "phase_excursion")
#: Weights of the spectrum's roughness penalty tried by the diagnosis (relative to the data): one, light
#: (a second weight doubled the settings to choose among, and the choice itself cost more than it bought).
SMOOTHING = (0.01,)
#: The weight when a model is fitted with creep (``rig identify --with``).
FIT_SMOOTHING = 0.01


def relax(t_s: np.ndarray, start_s: np.ndarray, amount: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """``(n, J)``: at every reading time ``t_s[n]``, ``sum_k amount_k exp(-(t_n - start_k) / tau_j)`` over
    the steps ``k <= n`` (step ``k`` happens at ``start_s[k] <= t_s[k]``)."""
    taus = np.asarray(taus, dtype=float)
    n = t_s.size
    out = np.empty((n, taus.size))
    state = np.zeros(taus.size)
    prev_t = t_s[0] if n else 0.0
    for k in range(n):
        state = state * np.exp(-max(t_s[k] - prev_t, 0.0) / taus)
        if amount[k]:
            state = state + amount[k] * np.exp(-max(t_s[k] - start_s[k], 0.0) / taus)
        out[k] = state
        prev_t = t_s[k]
    return out


def reversal_steps(run: Run) -> np.ndarray:
    """``(n,)``: at the first point after each reversal, the excursion (V) that ended there; 0 elsewhere."""
    h = run.history
    out = np.zeros(run.n)
    np.add.at(out, h.turn_index, h.excursion_V)
    return out


def output_steps(u: np.ndarray, u0: float | None = None) -> np.ndarray:
    """``(n,)``: the change of the output ``u`` (um) into every point, the first from ``u0`` (the output
    at the run's initial state; None: no change into the first point)."""
    return np.diff(np.asarray(u, dtype=float), prepend=(float(u[0]) if u0 is None else u0) if len(u) else 0.0)


def excursion_steps(u: np.ndarray, u0: float | None = None) -> np.ndarray:
    """``(n,)``: the change into every point of the output's excursion since the output last turned back
    (before its first turn: since the initial state, output ``u0``; None: since the first point).

    The turns are the output's own -- where its changes change sign -- not the input's: with a thermal
    term of the other sign the output can fall while the heater rises.  Changes below
    :data:`STILL` of the output's range do not turn it (a saturated phase part stays where it is).
    """
    u = np.asarray(u, dtype=float)
    if not u.size:
        return np.zeros(0)
    start = float(u[0]) if u0 is None else float(u0)
    before = np.concatenate([[start], u[:-1]])
    d = u - before
    still = STILL * max(float(np.ptp(np.concatenate([[start], u]))), 1e-300)
    anchor, direction = start, 0.0
    excursion = np.empty(u.size)
    for k in range(u.size):
        if abs(d[k]) > still:
            s = 1.0 if d[k] > 0 else -1.0
            if s != direction:
                anchor, direction = float(before[k]), s
        excursion[k] = u[k] - anchor
    return output_steps(excursion, 0.0)


def relaxations(run: Run, taus: np.ndarray, drive: str = "reversal", u: np.ndarray | None = None,
                u0: float | None = None) -> np.ndarray:
    """``(n, J)``: the relaxation columns of ``run`` for each time constant; ``u`` the output that drives
    it (``output``, ``excursion``: the model's; ``phase``, ``phase_excursion``: its phase-transition part)
    and ``u0`` its value at the run's initial state (the sequencer's saturation before the first point:
    on an identification run the rise from it is the largest change of the run, and a slow kernel still
    relaxes from it hours later)."""
    if drive == "reversal":
        steps = reversal_steps(run)
    elif drive in DRIVES:
        if u is None:
            raise IdentifyError(f"creep driven by the {drive} needs the model's output")
        steps = excursion_steps(u, u0) if drive in EXCURSION_DRIVES else output_steps(u, u0)
    else:
        raise IdentifyError(f"creep drive must be one of {', '.join(DRIVES)}, got {drive!r}")
    return relax(run.t_s, run.setpoint_t, steps, taus)


def _driver(ctx: Context, i: int, drive: str) -> np.ndarray:
    """What drives the relaxation on run ``i``: the model's output before the output effects, or its
    phase-transition part (without the bias and the thermal term)."""
    u = ctx.bare_output(i)
    if drive in PHASE_DRIVES:
        return u - ctx.model.mu0 - ctx.model.c_d * ctx.thermal[i]
    return u


def _start(ctx: Context, i: int, drive: str) -> float:
    """What drives the relaxation at run ``i``'s initial state (the first point's change is counted from it)."""
    u0, phase0 = start_of(ctx.model, ctx.runs[i].initial_V)
    return phase0 if drive in PHASE_DRIVES else u0


def _signs(setting: dict[str, float], k: int) -> np.ndarray:
    """``(k,)``: each time constant's sign: the setting's ``sign``, flipped from index ``split`` on."""
    signs = np.full(k, float(setting["sign"]))
    if setting.get("split") is not None:
        signs[int(setting["split"]):] *= -1.0
    return signs


def _rough(k: int) -> np.ndarray:
    d = np.diff(np.eye(k), n=2, axis=0)
    return d.T @ d


class Creep(Effect):
    name = "creep"
    summary = "the deflection relaxes slowly after the output changes"
    stage = OUTPUT
    must_record = (needs_time,)
    inversion = "offset"

    def inversion_refused(self) -> str | None:
        if (self.params or {}).get("drive") in EXCURSION_DRIVES:
            return ("driven by the excursion since the last reversal, its value at a reversal point depends on the "
                    "set-point after it (which makes the point a reversal); an inversion cannot know that in advance")
        return None

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        taus = finite_array(params, "time_constants_s", self.name)
        weights = finite_array(params, "weights_um_per_V", self.name) if "weights_um_per_V" in params else \
            finite_array(params, "weights", self.name)
        drive = params.get("drive", "reversal")
        if taus.size != weights.size or taus.size == 0 or np.any(taus <= 0) or drive not in DRIVES:
            raise IdentifyError(f"effect {self.name!r}: time_constants_s (> 0) and weights must match, drive one of "
                                f"{', '.join(DRIVES)}")
        return {"drive": drive, "time_constants_s": taus.tolist(), "weights": weights.tolist()}

    @property
    def needs_output(self) -> bool:
        return bool(self.params and self.params["drive"] != "reversal")

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        return self.applicable(runs) or needs_reversals(runs, "it relaxes after the output changes direction")

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"drive": d, "sign": s, "smoothing": w, **({} if k is None else {"split": k})}
                for d in DRIVES for s in (1.0, -1.0) for k in SPLITS for w in SMOOTHING]

    def fit_settings_grid(self) -> list[dict[str, float]]:
        return [{"drive": d, "sign": s, "smoothing": FIT_SMOOTHING, **({} if k is None else {"split": k})}
                for d in DRIVES for s in (1.0, -1.0) for k in SPLITS]

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        taus = np.asarray(TIME_CONSTANTS_S)
        drive = setting.get("drive", "reversal")
        values = [_signs(setting, taus.size) * relaxations(r, taus, drive, _driver(ctx, i, drive), _start(ctx, i, drive))
                  for i, r in enumerate(ctx.runs)]
        unit = "um_per_V" if drive == "reversal" else "fraction"  # of the input excursion, or of the change
        labels = tuple(f"{unit}_at_{tau:.3g}s" for tau in taus)
        k = taus.size
        return Columns(tuple(values), labels, (True,) * k, (-1,) * k, _rough(k), setting.get("smoothing", 0.0))

    def with_fit(self, ctx, setting, coef, cols) -> "Creep":
        w = _signs(setting, len(TIME_CONSTANTS_S)) * np.asarray(coef, dtype=float)
        return Creep({"drive": setting.get("drive", "reversal"), "time_constants_s": list(TIME_CONSTANTS_S),
                      "weights": w.tolist()})

    def contribution(self, run: Run, u: np.ndarray | None = None, phase: np.ndarray | None = None,
                     start: tuple[float, float] | None = None) -> np.ndarray:
        p = self.params
        driver = phase if p["drive"] in PHASE_DRIVES else u
        u0 = None if start is None else start[1 if p["drive"] in PHASE_DRIVES else 0]
        return relaxations(run, np.asarray(p["time_constants_s"]), p["drive"], driver, u0) @ np.asarray(p["weights"])

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        w = np.asarray(self.params["weights"])
        taus = np.asarray(self.params["time_constants_s"])
        mean_tau = float(np.sum(np.abs(w) * taus) / max(float(np.sum(np.abs(w))), 1e-300))
        unit = "um_per_V" if self.params["drive"] == "reversal" else "fraction"
        return {"drive": self.params["drive"], unit: float(w.sum()), "mean_time_constant_s": mean_tau,
                "spectrum": {f"at_{t:.3g}s": float(x) for t, x in zip(taus, w)}}
