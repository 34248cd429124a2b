"""``resolution``: the gap a coarse grid leaves -- the same base model on a finer grid.

Equation (22) on ``L`` levels has a density that is uniform inside each
cell.  A real film's density is not, and wherever the input stops between
two walls the uniform cell misplaces part of its weight: a gap that no
unmodelled effect explains and a finer grid closes.  This candidate scores
that explanation like any effect (held out, on the check runs' blocks), with
the finer levels ``L'`` chosen by the same cross-validation, in one of three
ways depending on what the runs can identify:

* ``refit`` -- the identification runs hold enough distinct inputs for ``L'``
  levels (a FORC measurement, a random run): the base model is identified
  again on them at ``L'`` (the same method), exactly what ``rig identify
  --levels L'`` stores; the candidate's one column is that model's output
  minus the base model's.
* ``check_runs`` -- they do not (a damped oscillation visits only the walls
  of its own grid) but the finer grid is small: the fine cells' signed areas
  are the columns, fitted jointly with the base model on the check runs'
  training blocks like any effect, with the density's roughness penalty
  (weight chosen by cross-validation).  A model on ``L'`` levels then needs
  an identification run on ``L'`` levels.
* ``interpolated`` -- neither: the base density redistributed smoothly inside
  each of its cells on a grid ``q`` times finer (each cell keeps its weight);
  one column, the change of the output.  A weak estimate of the part of the
  gap that resolution explains; it never claims more than one coefficient.

``levels`` are bounded by the distinct inputs the runs hold (a grid of
``L'`` levels needs at least ``L' + 1`` distinct inputs to be identified) and
by :data:`MAX_LEVELS`; the bound is reported when it stops the search.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from ..effects.base import OUTPUT, Columns, Context, Effect, EffectNotApplicable, EffectNotIdentifiable
from ..effects.joint import JointFit, fit_with_effects
from ..errors import MethodNotApplicable
from ..grid import Grid, n_cells
from ..methods.triangle_penalty import dense_roughness_matrix
from ..model import PreisachModel
from ..regressor import regressor_matrix
from ..runs import Run
from .base import fit_model

#: Finer grids tried, as multiples of the base grid's levels.
LADDER = (1.5, 2.0, 3.0, 4.0)
#: The finest grid the candidate tries (levels).
MAX_LEVELS = 120
#: ``check_runs`` mode: at most this many fine cells (columns of the joint fit).
MAX_CHECK_CELLS = 210
#: ``check_runs`` mode: roughness weights tried (relative to the data, as every penalised candidate).
SMOOTHING = (0.1, 1.0)
#: ``interpolated`` mode: the refinement factors tried.
INTERPOLATION_FACTORS = (2, 4)
#: Inputs closer than this fraction of the range count as the same input.
SAME_INPUT = 1e-9

MODES = ("refit", "check_runs", "interpolated")


def distinct_inputs(runs: tuple[Run, ...] | list[Run], grid: Grid, measured_only: bool = True) -> int:
    """How many distinct inputs inside ``grid``'s range the runs hold (measured points only by default)."""
    values = []
    for r in runs:
        v = r.inputs[r.rows] if measured_only else r.inputs
        values.append(v[(v >= grid.v_min) & (v <= grid.v_max)])
    v = np.concatenate(values) if values else np.zeros(0)
    if not v.size:
        return 0
    q = np.round((v - grid.v_min) / ((grid.v_max - grid.v_min) * SAME_INPUT))
    return int(np.unique(q).size)


def refine_density(model: PreisachModel, factor: int) -> PreisachModel:
    """``model`` on a grid ``factor`` times finer, each coarse cell's weight redistributed smoothly inside it.

    The density (weight per area) at the fine cells' centres is interpolated
    linearly between the coarse cells' centres (mirrored across the diagonal,
    clipped at zero), then scaled inside every coarse cell so that its fine
    cells add up to its weight: on the coarse walls the two models agree.
    """
    g = model.grid
    levels, fine = g.levels, factor * g.levels
    gf = Grid(fine, g.v_min, g.v_max)
    weights = g.density_matrix(model.density)
    lower = np.tri(levels, dtype=bool)
    area = np.ones((levels, levels))
    np.fill_diagonal(area, 0.5)
    dens = np.where(lower, weights / area, 0.0)
    full = np.where(lower, dens, dens.T)
    centres = np.arange(levels) + 0.5
    interp = RegularGridInterpolator((centres, centres), full, bounds_error=False, fill_value=None)
    fc = (np.arange(fine) + 0.5) / factor
    a, b = np.meshgrid(fc, fc, indexing="ij")
    fine_dens = np.maximum(interp(np.stack([a, b], axis=-1)), 0.0)
    fine_area = np.ones((fine, fine))
    np.fill_diagonal(fine_area, 0.5)
    fine_w = np.where(np.tri(fine, dtype=bool), fine_dens * fine_area, 0.0)
    ci, cj = np.meshgrid(np.arange(fine) // factor, np.arange(fine) // factor, indexing="ij")
    total = np.zeros((levels, levels))
    np.add.at(total, (ci, cj), fine_w)
    # a coarse cell whose interpolated density vanished keeps its weight, spread evenly
    even = np.where(np.tri(fine, dtype=bool), fine_area, 0.0)
    even_total = np.zeros((levels, levels))
    np.add.at(even_total, (ci, cj), even)
    use = total > 0
    scaled = np.where(use[ci, cj], fine_w * np.where(use, weights / np.where(use, total, 1.0), 0.0)[ci, cj],
                      even * np.where(even_total > 0, weights / np.where(even_total > 0, even_total, 1.0), 0.0)[ci, cj])
    return PreisachModel(gf, scaled[gf.cell_alpha, gf.cell_beta], model.mu0, model.c_d,
                         input_unit=model.input_unit, output_unit=model.output_unit)


def joint_refit_refused(effect: Effect) -> str | None:
    """Why ``effect`` is not identified together with a finer grid (:meth:`Resolution.refit_with`), or None.

    Only an effect whose joint fit is one solve -- an output term (not linearised at the base model, no
    feedback) with a single setting -- is: on the shared FORC file at L' = 60 (3,061 points) that fit took
    4 s, where ``creep`` (ten settings searched) took 172 s and ``sensor_nonlinearity`` (linearised again
    at every step) 428 s on the same loaded machine.  The others are paired with the finer grid's own
    column instead, which the grid fitted without them may already have absorbed in part.
    """
    if effect.per_run:
        return f"{effect.name} is fitted per run and cannot predict the check runs"
    if (effect.stage != OUTPUT or effect.from_base or effect.loop() is not None
            or len(effect.fit_settings_grid()) != 1):
        return (f"{effect.name}'s joint fit with a finer grid is not one solve (a search over its settings or "
                f"a fit linearised again at every step)")
    return None


@dataclass(frozen=True, eq=False)
class _Plan:
    """The settings the runs allow, and why the search stopped where it did."""

    settings: tuple[dict[str, float], ...]
    bound: str


class Resolution:
    """The ``resolution`` candidate (see the module doc).  Built for the runs of one diagnosis:
    ``n_fit`` leading runs of every :class:`Context` are the identification runs."""

    name: ClassVar[str] = "resolution"
    summary: ClassVar[str] = "the grid is too coarse: the same model on a finer grid"
    stage: ClassVar[str] = OUTPUT
    per_run: ClassVar[bool] = False
    within: ClassVar[str | None] = None

    def __init__(self, grid: Grid, fit_runs: tuple[Run, ...], check_runs: tuple[Run, ...], method: str = "ls",
                 thermal_term: bool = True, method_settings: dict[str, Any] | None = None,
                 params: dict[str, Any] | None = None) -> None:
        self.grid = grid
        self.fit_runs = tuple(fit_runs)
        self.check_runs = tuple(check_runs)
        self.method = method
        self.thermal_term = thermal_term
        self.method_settings = method_settings
        self.params = params
        self._plan = self._make_plan()
        self._refits: dict[int, PreisachModel] = {}
        self._joint: dict[tuple[int, str], JointFit | str] = {}

    # ------------------------------------------------------------ what the runs allow
    def _make_plan(self) -> _Plan:
        base = self.grid.levels
        ladder = sorted({int(round(f * base)) for f in LADDER} - {base})
        ladder = [lv for lv in ladder if lv > base]
        fit_distinct = distinct_inputs(self.fit_runs, self.grid)
        all_distinct = distinct_inputs(self.fit_runs + self.check_runs, self.grid)
        fit_points = sum(r.rows.size for r in self.fit_runs)
        settings: list[dict[str, float]] = []
        for lv in ladder:
            if lv > MAX_LEVELS:
                continue
            if lv + 1 <= fit_distinct and n_cells(lv) <= fit_points:
                settings.append({"levels": float(lv), "mode": 0.0})
            elif lv + 1 <= all_distinct and n_cells(lv) <= MAX_CHECK_CELLS:
                settings += [{"levels": float(lv), "mode": 1.0, "smoothing": w} for w in SMOOTHING]
        if not settings:
            settings = [{"levels": float(f * base), "mode": 2.0} for f in INTERPOLATION_FACTORS
                        if f * base <= MAX_LEVELS]
        bound = (f"the identification runs hold {fit_distinct} distinct inputs and all runs {all_distinct}; "
                 f"a grid of L levels needs at least L + 1")
        return _Plan(tuple(settings), bound)

    @property
    def bound(self) -> str:
        """Why the finer grids stop where they do (the runs' distinct inputs)."""
        return self._plan.bound

    def applicable(self, runs: tuple[Run, ...]) -> str | None:
        if not self._plan.settings:
            return (f"no grid finer than L = {self.grid.levels} can be identified or estimated here "
                    f"({self._plan.bound}; at most {MAX_LEVELS} levels)")
        return None

    def settings_grid(self) -> list[dict[str, float]]:
        return [dict(s) for s in self._plan.settings]

    def bounds(self) -> dict[str, float]:
        return {}

    # ------------------------------------------------------------ columns
    def refit(self, levels: int) -> PreisachModel:
        """The base model identified again on the identification runs at ``levels`` (cached)."""
        if levels not in self._refits:
            grid = Grid(levels, self.grid.v_min, self.grid.v_max)
            est, *_ = fit_model(grid, self.fit_runs, self.method, thermal_term=self.thermal_term,
                                settings=self.method_settings)
            self._refits[levels] = est.model_
        return self._refits[levels]

    def refit_with(self, levels: int, effect: Effect) -> JointFit | str:
        """The base model and ``effect`` (unfitted) identified jointly on the identification runs at
        ``levels`` -- what ``rig identify --levels L --with EFFECT`` stores -- or why it cannot be (a
        per-run effect describes only the runs it was fitted on; an effect the runs cannot identify).
        Cached."""
        key = (levels, effect.spec)
        if key not in self._joint:
            why = joint_refit_refused(effect)
            if why is not None:
                self._joint[key] = why
            else:
                grid = Grid(levels, self.grid.v_min, self.grid.v_max)
                try:
                    self._joint[key] = fit_with_effects(grid, self.fit_runs, self.method, [effect],
                                                        thermal_term=self.thermal_term,
                                                        settings=self.method_settings)
                except (EffectNotIdentifiable, MethodNotApplicable) as exc:
                    self._joint[key] = str(exc)
        return self._joint[key]

    def joint_columns(self, ctx: Context, levels: int, effect: Effect) -> Columns | None:
        """One column: the output of :meth:`refit_with` minus the base model's at every point of every
        run of ``ctx``, ``(n_i, 1)`` each; None when there is no such model or it cannot predict a run."""
        joint = self.refit_with(levels, effect)
        if isinstance(joint, str):
            return None
        try:
            values = tuple((joint.model.predict_run(r) - ctx.predictions[i]).reshape(-1, 1)
                           for i, r in enumerate(ctx.runs))
        except EffectNotApplicable:
            return None
        return Columns(values, (f"L{levels}+{effect.spec}",), (False,), (-1,))

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        levels, mode = int(setting["levels"]), MODES[int(setting["mode"])]
        if mode == "refit":
            model = self.refit(levels)
            values = tuple((model.predict(r.inputs) - ctx.predictions[i]).reshape(-1, 1) for i, r in enumerate(ctx.runs))
            return Columns(values, (f"L{levels}",), (False,), (-1,))
        if mode == "interpolated":
            return Columns(self._interpolated(ctx, levels), (f"L{levels}",), (False,), (-1,))
        # the fine cells, penalised for roughness, as a correction to the base density refined smoothly
        # (a column of its own, unpenalised): a smooth fine density is then a smooth correction, where
        # a correction to the coarse density itself would have to undo its steps
        grid = Grid(levels, self.grid.v_min, self.grid.v_max)
        cells = grid.n_cells
        smooth = self._interpolated(ctx, levels)
        values = tuple(np.hstack([regressor_matrix(grid, r.inputs, False)[:, :cells], smooth[i]])
                       for i, r in enumerate(ctx.runs))
        rough = np.zeros((cells + 1, cells + 1))
        rough[:cells, :cells] = dense_roughness_matrix(grid)
        return Columns(values, (*(f"cell{j}" for j in range(cells)), f"L{levels}"), (False,) * (cells + 1),
                       (-1,) * (cells + 1), rough, float(setting.get("smoothing", 0.0)))

    def _interpolated(self, ctx: Context, levels: int) -> tuple[np.ndarray, ...]:
        """The output change of the base density refined smoothly onto ``levels`` (a multiple of the base
        grid's, else the nearest), ``(n_i, 1)`` per run."""
        factor = max(2, int(round(levels / self.grid.levels)))
        fine = refine_density(ctx.model.without_effects(), factor)
        return tuple((fine.predict(r.inputs) - ctx.model.predict(r.inputs)).reshape(-1, 1) for r in ctx.runs)

    # ------------------------------------------------------------ the fit, reported
    def with_fit(self, ctx: Context, setting: dict[str, float], coef: np.ndarray, cols: Columns) -> "Resolution":
        levels, mode = int(setting["levels"]), MODES[int(setting["mode"])]
        params: dict[str, Any] = {"levels": levels, "mode": mode}
        if cols.k == 1:
            params["coefficient"] = float(np.asarray(coef).ravel()[0])
        fitted = Resolution(self.grid, self.fit_runs, self.check_runs, self.method, self.thermal_term,
                            self.method_settings, params)
        fitted._refits, fitted._joint = self._refits, self._joint  # the same runs: the same fits
        return fitted

    def report(self, runs: tuple[Run, ...] = ()) -> dict[str, Any]:
        return dict(self.params or {})


__all__ = ["MODES", "Resolution", "distinct_inputs", "joint_refit_refused", "refine_density"]
