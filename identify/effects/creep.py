"""``creep``: the deflection relaxes slowly after each reversal.

After each reversal the output is offset by ``E_r K(t - t_r)`` and relaxes
(um): ``E_r`` the excursion (V) that ended at the reversal, ``t_r`` the
time the input turned back; transients add up.  The kernel is a
relaxation spectrum, ``K(t) = s sum_j a_j exp(-t / tau_j)`` with
``a_j >= 0`` over :data:`TIME_CONSTANTS_S` and one sign ``s`` (a setting),
so it decays monotonically whatever its shape (a Prony series
approximates any completely monotone kernel over seconds to an hour).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..grid import Grid
from ..runs import Run
from .base import OUTPUT, Columns, Context, Effect, finite_array, needs_reversals, needs_time, single_columns

#: Relaxation times of the kernel (s).
TIME_CONSTANTS_S = (10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0)


def relaxations(run: Run, taus: np.ndarray) -> np.ndarray:
    """``(n, J)``: after each reversal, the excursion times ``exp(-(t - t_r) / tau_j)``, summed over reversals."""
    h = run.history
    out = np.zeros((run.n, len(taus)))
    for r, (first, t_r, e) in enumerate(zip(h.turn_index, h.turn_t, h.excursion_V)):
        dt = run.t_s[first:] - t_r
        out[first:] += e * np.exp(-np.clip(dt, 0.0, None)[:, None] / np.asarray(taus)[None, :])
    return out


class Creep(Effect):
    name = "creep"
    summary = "the deflection relaxes slowly after each reversal"
    stage = OUTPUT

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        taus = finite_array(params, "time_constants_s", self.name)
        weights = finite_array(params, "weights_um_per_V", self.name)
        if taus.size != weights.size or taus.size == 0 or np.any(taus <= 0):
            raise IdentifyError(f"effect {self.name!r}: time_constants_s (> 0) and weights_um_per_V must match")
        return {"time_constants_s": taus.tolist(), "weights_um_per_V": weights.tolist()}

    def applicable(self, runs: tuple[Run, ...]) -> str | None:
        return needs_time(runs)

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        return self.applicable(runs) or needs_reversals(runs, "it relaxes after reversals")

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"sign": 1.0}, {"sign": -1.0}]

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        taus = np.asarray(TIME_CONSTANTS_S)
        values = [setting["sign"] * relaxations(r, taus) for r in ctx.runs]
        labels = tuple(f"um_per_V_at_{tau:g}s" for tau in taus)
        return single_columns(ctx.runs, values, labels, (True,) * taus.size)

    def with_fit(self, ctx, setting, coef, cols) -> "Creep":
        w = setting["sign"] * np.asarray(coef, dtype=float)
        return Creep({"time_constants_s": list(TIME_CONSTANTS_S), "weights_um_per_V": w.tolist()})

    def contribution(self, run: Run) -> np.ndarray:
        p = self.params
        return relaxations(run, np.asarray(p["time_constants_s"])) @ np.asarray(p["weights_um_per_V"])

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        w = np.asarray(self.params["weights_um_per_V"])
        taus = np.asarray(self.params["time_constants_s"])
        mean_tau = float(np.sum(np.abs(w) * taus) / max(float(np.sum(np.abs(w))), 1e-300))
        return {"um_per_V": float(w.sum()), "mean_time_constant_s": mean_tau,
                "spectrum_um_per_V": {f"um_per_V_at_{t:g}s": float(x) for t, x in zip(taus, w)}}
