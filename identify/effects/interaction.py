"""``interaction``: mean-field interaction between hysterons (the "moving" Preisach model).

The hysterons see the input plus a multiple of the output, ``x = v + k u``
(``k`` in input units per output unit) -- or, a setting, the heater power
plus a multiple of it, ``x^2 = v^2 + k u`` (the temperature the
transition sees moves with the deflection).  What they feel is the whole
output or, a setting, its phase-transition part alone, counted from where
the mean field is zero (``reference``, a setting): the middle of the
transition, the insulating state (a film stress-free as deposited, cold) or
the metallic one -- ``x = v + k (P - P_ref)``, ``P_ref`` = 0, ``-sum mu`` or
``+sum mu`` (``reference_um``, kept with ``k``).  On the VO2 actuator the
transition temperature moves with stress, which the deflection itself
changes; in a magnetic sample the field each grain feels includes the
sample's magnetisation.  ``k > 0`` steepens and widens the loop, ``k < 0``
shears it.

* **Fitting** takes the output the hysterons feel from the run itself --
  the measured output where measured, the model's prediction elsewhere
  (:attr:`identify.effects.base.Context.feedback`) -- so for a given ``k``
  the regressor is exact and ``k`` is found by Gauss--Newton steps.
* **Prediction** has no measurement to lean on: the output depends on the
  memory state, which depends on the output.  Each step solves the fixed
  point exactly along the memory curve (:mod:`identify.effects.compose`).

Not identifiable from a run whose input never turns back.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import IdentifyError
from ..grid import Grid
from ..runs import Run
from .base import (INPUT, Columns, Context, Effect, Loop, felt, finite, needs_reversals, require_params,
                   single_columns)

#: Step of the secant in ``k``, relative to the input range over the output range.
STEP = 1e-3
#: What the output feeds back into (a setting): the input in volts, or the heater power (V^2).
DRIVES = ("voltage", "power")
#: What the hysterons feel (a setting): the whole output, or its phase-transition part (without the bias
#: and the thermal term).
SOURCES = ("output", "phase")
#: Where the phase part's mean field is zero (a setting of source ``phase``): its middle (0), the insulating
#: state (every cell at -1) or the metallic one (every cell at +1).  Until 2026-11-29 the middle alone: on the
#: five blind generators' headlines every mean field counted from the insulating state went unnamed (0 of 8).
REFERENCES = ("mid", "insulating", "metallic")
#: What the hysterons feel, and from where: the whole output (from the sensor's zero), or the phase part.
FELT = (("output", "mid"), *(("phase", r) for r in REFERENCES))
#: Where the joint fit starts ``k`` (relative to the input range over the output range): the
#: measured-feedback residual can have local minima when the feedback is strong.
STARTS = (-0.5, -0.2, 0.0, 0.2, 0.5)


class Interaction(Effect):
    name = "interaction"
    summary = "mean-field interaction: the hysterons feel the output as well as the input (x = v + k u)"
    stage = INPUT
    inversion = "feedback"

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        require_params(params, ("k",), self.name)
        drive = params.get("drive", "voltage")
        source = params.get("source", "output")
        if drive not in DRIVES or source not in SOURCES:
            raise IdentifyError(f"effect {self.name!r}: drive must be one of {', '.join(DRIVES)}, source one of "
                                f"{', '.join(SOURCES)}")
        reference = params.get("reference", "mid")
        if reference not in REFERENCES or (source == "output" and reference != "mid"):
            raise IdentifyError(f"effect {self.name!r}: reference must be one of {', '.join(REFERENCES)} "
                                "(mid for source output)")
        out = {"k": finite(params, "k", self.name), "drive": drive, "source": source}
        if reference != "mid":
            out.update(reference=reference, reference_um=finite(params, "reference_um", self.name))
        return out

    @property
    def drive(self) -> str:
        return self.params.get("drive", "voltage") if self.fitted else "voltage"

    @property
    def source(self) -> str:
        return self.params.get("source", "output") if self.fitted else "output"

    @property
    def k(self) -> float:
        return self.params["k"] if self.fitted else 0.0

    @property
    def reference_um(self) -> float:
        """The phase part (um) where the fitted mean field is zero."""
        return float(self.params.get("reference_um", 0.0)) if self.fitted else 0.0

    def loop(self) -> Loop | None:
        return Loop(self.k, self.drive, self.source, self.reference_um) if self.fitted and self.k != 0.0 else None

    def identifiable(self, runs: tuple[Run, ...], grid: Grid) -> str | None:
        return needs_reversals(runs, "mean-field feedback shows only where the input turns back")

    def inverted_as(self) -> str | None:
        """``feedback`` (``x = v + k u``: find ``x`` for the target, then ``v = x - k u``); ``inert`` at ``k = 0``."""
        return "inert" if self.k == 0.0 else self.inversion

    def inversion_refused(self) -> str | None:
        p = self.params or {}
        if self.inverted_as() == "inert" or (self.drive == "voltage" and self.source == "output"):
            return None
        return (f"driven by {p.get('drive')} and felt through the {p.get('source')}, the hysterons' input is not a "
                "polynomial of the set-point on a piece (only drive 'voltage' with source 'output' is inverted exactly)")

    def settings_grid(self) -> list[dict[str, float]]:
        return [{"drive": d, "source": o, "reference": r, "sign": g} for d in DRIVES for o, r in FELT for g in (1.0, -1.0)]

    def fit_settings_grid(self) -> list[dict[str, float]]:
        return [{"drive": d, "source": o, "reference": r, "start": s} for d in DRIVES for o, r in FELT for s in STARTS]

    def with_setting(self, setting: dict[str, float], ctx: Context | None = None) -> "Interaction":
        if self.fitted or ctx is None:
            return self
        drive = setting.get("drive", "voltage")
        scale = _scale(ctx, drive)
        return Interaction({"k": float(setting.get("start", 0.0)) * scale, "drive": drive,
                            "source": setting.get("source", "output"),
                            **_reference(ctx, setting.get("source", "output"), setting.get("reference", "mid"))})

    def transform(self, run: Run, x: np.ndarray, feedback: np.ndarray | None = None) -> np.ndarray:
        if not self.k:
            return x
        if feedback is None:
            raise ValueError("interaction needs the output the hysterons feel (prediction solves a fixed point)")
        return shifted(x, self.k * feedback, self.drive)

    def columns(self, ctx: Context, setting: dict[str, float]) -> Columns:
        drive = self.drive if self.fitted else setting.get("drive", "voltage")
        source = self.source if self.fitted else setting.get("source", "output")
        # unfitted (the diagnosis): a one-sided derivative in the setting's direction, its coefficient >= 0.
        # At the grid's ends the output is not differentiable in k: at the top wall a feedback that pushes
        # the input further up changes nothing (it saturates), one that pulls it down unswitches cells; a
        # derivative taken upwards only left every k < 0 out of the family
        sign = self._direction(setting)
        reference = self.reference_um if self.fitted else _reference(ctx, source, setting.get("reference", "mid")).get(
            "reference_um", 0.0)
        unit = STEP * _scale(ctx, drive)
        dk = sign * unit
        values = []
        for i, run in enumerate(ctx.runs):
            x = ctx.inputs[i]
            fb = felt(ctx.feedback[i], source, ctx.model.mu0, ctx.model.c_d, ctx.thermal[i]) - reference
            # the input before this effect: the current one minus the current feedback (in its own units)
            before = shifted(x, -self.k * fb, drive) if self.k else x
            moved = shifted(before, (self.k + dk) * fb, drive)
            values.append(((ctx.response(i, moved) - ctx.response(i, x)) / unit)[:, None])
        return single_columns(ctx.runs, values, ("k",), (not self.fitted,))

    def with_fit(self, ctx, setting, coef, cols) -> "Interaction":
        drive = self.drive if self.fitted else setting.get("drive", "voltage")
        source = self.source if self.fitted else setting.get("source", "output")
        return Interaction({"k": float(self.k + self._direction(setting) * coef[0]), "drive": drive,
                            "source": source,
                            **_reference(ctx, source, (self.params if self.fitted else setting).get("reference", "mid"))})

    def _direction(self, setting: dict[str, float]) -> float:
        """The direction of ``k`` a column is taken in: the setting's sign unfitted (the diagnosis), else up
        (a fitted ``k`` is refined both ways by Gauss--Newton)."""
        return 1.0 if self.fitted else float(setting.get("sign", 1.0))


def shifted(x: np.ndarray, amount: np.ndarray, drive: str) -> np.ndarray:
    """The hysterons' input ``x`` moved by ``amount``: in volts, or in heater power (``sqrt(x^2 + amount)``)."""
    if drive == "power":
        return np.sign(x) * np.sqrt(np.maximum(x * x + amount, 0.0)) if np.any(x) else np.sqrt(np.maximum(amount, 0.0))
    return x + amount


def _reference(ctx: Context, source: str, reference: str) -> dict[str, Any]:
    """The parameters of ``reference`` at ``ctx``'s model: none for the middle (or the whole output), else its
    name and the phase part there (um): ``-sum mu`` insulating, ``+sum mu`` metallic."""
    if reference == "mid" or source == "output":
        return {}
    total = float(np.sum(ctx.model.density))
    return {"reference": reference, "reference_um": -total if reference == "insulating" else total}


def _scale(ctx: Context, drive: str) -> float:
    """``k``'s natural scale: the input range (in the drive's units) per output range."""
    g = ctx.grid
    span = g.v_max - g.v_min if drive == "voltage" else max(g.v_max ** 2, g.v_min ** 2)
    return span / (2.0 * ctx.output_half_range)
