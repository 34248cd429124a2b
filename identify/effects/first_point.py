"""``first_point``: the first reading after a reversal differs systematically.

At a reversal the input turns back; the readings right there are taken
after a change of direction that the rest of a branch does not see (the
FORC "first-point artefact" at each curve's reversal field; on the VO2 rig,
the first dwell after the heater turns back).  Two places, each with an
offset (um) that may depend on the direction and on the size of a step:

* at the reversal point: ``a0 + a1 sign(E) + a2 E``, ``E`` the excursion
  (input units, signed) that ended there;
* at the first point after it: ``(b0 + b1 d) + (b4 + b2 d) |s| + (b5 + b3 d)
  sat(|s|)``, ``s`` the reversing step (signed, input units), ``d`` its
  direction and ``sat`` a saturating function of its size (``1 - exp(-|s| /
  h)``, ``h`` the grid's cell): a size that is constant, linear in the step
  or saturating, each of a fixed sign, of the new direction's sign, or a
  mix (different up and down) -- optionally persisting over the next points,
  decaying geometrically by a ratio ``decay`` per point (a setting).

Whether the reversal point itself has an offset is a setting too (``at``):
a run whose reversal readings carry none should not pay for three terms.

The start of a run is a turn too: the sequencer starts every run from the
heater at 0 V, where the film has cooled into saturation, so the first
set-point that rises from ``initial_V`` is the first point after the input
turned from falling to rising.  Its step (the whole jump from 0 V) is far
larger than any turn inside the run, so it has its own offset ``c0``
(persisting like the others), not a share of the size terms: one large
step would otherwise set the slope every other turn is predicted with.

Derived from the input history alone (:class:`identify.runs.History`), not
from time, so any run with reversals carries it; a run whose input never
turns back cannot identify it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..grid import Grid
from ..runs import Run
from .base import OUTPUT, Columns, Context, Effect, finite, finite_array, needs_reversals, single_columns

LABELS = ("at_offset_um", "at_direction_um", "at_um_per_V", "after_offset_um", "after_direction_um",
          "after_um_per_V", "after_saturating_um", "after_size_um_per_V", "after_saturating_size_um",
          "start_offset_um")
#: Decay ratios of the after-reversal offset over the following points (a setting).
DECAYS = (0.0, 0.3, 0.6, 0.85)
#: Points after the first over which a persisting offset is followed.
PERSIST = 4


def indicators(run: Run, decay: float = 0.0, cell: float = 1.0) -> np.ndarray:
    """``(n, 10)``: the terms above at every point (zero away from reversals and the run's first rise), in
    :data:`LABELS`' order; ``cell`` the saturation's scale."""
    h = run.history
    out = np.zeros((run.n, len(LABELS)))
    e = h.excursion_V
    out_at = np.stack([np.ones_like(e), np.sign(e), e], axis=1)
    np.add.at(out, (h.reversal_index[:, None], np.arange(3)[None, :]), out_at)
    # the offset is a reading's: a turn whose first point is applied without a reading (a FORC's return
    # towards saturation) has no first reading to offset, and its terms would be extrapolated unfitted
    read = np.isfinite(run.outputs[h.turn_index])
    turn, rev = h.turn_index[read], h.reversal_index[read]
    step = run.inputs[turn] - run.inputs[rev]
    d = np.sign(step)
    sat = 1.0 - np.exp(-np.abs(step) / cell)
    after = np.stack([np.ones_like(step), d, step, d * sat, np.abs(step), sat], axis=1)
    moved = np.flatnonzero(run.inputs != run.initial_V)
    first = moved[:1] if moved.size and run.inputs[moved[0]] > run.initial_V and \
        np.isfinite(run.outputs[moved[0]]) else moved[:0]
    for j in range(PERSIST + 1 if decay else 1):
        idx = turn + j
        ok = idx < run.n
        np.add.at(out, (idx[ok][:, None], 3 + np.arange(after.shape[1])[None, :]), (decay ** j) * after[ok])
        start = first + j
        out[start[start < run.n], 9] += decay ** j
    return out


#: A term whose part independent of the others is below this share of its size on the fit's readings is
#: dropped (coefficient 0): every curve of a FORC turns upwards by about the same field step, so the
#: direction, step and saturating terms repeat the offset there, and a fit of them is an arbitrary
#: cancellation (coefficients of 1e4 um) that a held-out curve with another step turns into error.
SEPARABLE = 1e-3


def separable(values: np.ndarray) -> np.ndarray:
    """Indices of the columns of ``values`` ``(m, k)`` (the terms at the fit's readings) that can be told
    apart: pivoted QR on the unit-norm columns, kept while ``|R_jj|`` >= :data:`SEPARABLE` ``|R_00|``."""
    import scipy.linalg

    norms = np.linalg.norm(values, axis=0)
    live = np.flatnonzero(norms > 0)
    if live.size == 0:
        return live
    _, r, piv = scipy.linalg.qr(values[:, live] / norms[live], mode="economic", pivoting=True)
    d = np.abs(np.diag(r))
    return np.sort(live[piv[: int(np.sum(d >= SEPARABLE * d[0]))]])


class FirstPoint(Effect):
    name = "first_point"
    summary = "the first reading after a reversal differs systematically (a first-point artefact)"
    stage = OUTPUT

    def inversion_refused(self) -> str | None:
        return ("its offset after a turn grows with the reversing step through a saturating exponential, which no "
                "polynomial piece holds")

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        decay = finite(params, "decay", self.name) if "decay" in params else 0.0
        cell = finite(params, "cell", self.name) if "cell" in params else 1.0
        coef = finite_array(params, "coefficients_um", self.name)
        if coef.size in (6, 7, 9):  # written before the saturating term, the unsigned sizes, or the start
            coef = np.append(coef, np.zeros(len(LABELS) - coef.size))
        if coef.size != len(LABELS) or cell <= 0:
            raise IdentifyError(f"effect {self.name!r}: needs {len(LABELS)} coefficients_um and cell > 0")
        return {"coefficients_um": coef.tolist(), "terms": list(LABELS), "decay": decay, "cell": cell}

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        why = needs_reversals(runs, "it acts where the input turns back")
        if why is not None:
            return why
        if not any(np.any(np.isfinite(r.outputs[r.history.reversal_index])) or
                   np.any(np.isfinite(r.outputs[r.history.turn_index])) for r in runs):
            return "no reading was taken at a reversal or right after one"
        return None

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"decay": d, "at": a} for d in DECAYS for a in (0.0, 1.0)]

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        decay = setting.get("decay", 0.0)
        at = bool(setting.get("at", 1.0))
        keep = np.arange(len(LABELS)) if at else np.arange(3, len(LABELS))
        values = [indicators(r, decay, ctx.grid.step)[:, keep] for r in ctx.runs]
        told = separable(np.vstack([v[r.rows] for v, r in zip(values, ctx.runs)]))
        return single_columns(ctx.runs, [v[:, told] for v in values], tuple(LABELS[k] for k in keep[told]))

    def with_fit(self, ctx, setting, coef, cols) -> "FirstPoint":
        full = np.zeros(len(LABELS))
        full[[LABELS.index(label) for label in cols.labels]] = np.asarray(coef, dtype=float)
        return FirstPoint({"coefficients_um": full.tolist(), "decay": setting.get("decay", 0.0), "cell": ctx.grid.step})

    def contribution(self, run: Run, u: np.ndarray | None = None, phase: np.ndarray | None = None,
                     start: tuple[float, float] | None = None) -> np.ndarray:
        p = self.params
        return indicators(run, p["decay"], p["cell"]) @ np.asarray(p["coefficients_um"])

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        return {**dict(zip(LABELS, self.params["coefficients_um"])), "decay": self.params["decay"]}
