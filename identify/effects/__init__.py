"""Unmodelled effects as model terms: one module per effect, one registry.

Each effect (:class:`~identify.effects.base.Effect`) is a physical
mechanism beside equation (22), with terms that the identification methods
fit jointly with the density (:mod:`identify.effects.joint`), parameters a
stored model keeps (``"effects": [{"name", "params"}]`` in the model JSON),
and a way to act on any run that records what it needs
(:mod:`identify.effects.compose`).  The gap diagnosis
(:mod:`identify.diagnosis`) scores the same effects as candidates.

===================== ======== ==============================================================
name                  stage    what it is
===================== ======== ==============================================================
``thermal_lag``       input    part of the heating is slow: the beam is read short of its set-point
``baseline_drift``    output   the sensor zero drifts over session time (per run)
``ambient_drift``     input    the room temperature drifts, shifting the transition (per run)
``gain_drift``        output   the sensor's sensitivity drifts over session time (per run)
``joule_power``       output   the thermal-expansion term follows heater power (v^2)
``creep``             output   the deflection relaxes after each reversal
``sensor_nonlinearity`` sensor the reading is a nonlinear function of the deflection
``reversible``        output   a smooth single-valued function of the input (replaces ``c_d v``)
``interaction``       input    mean-field feedback: the hysterons feel ``v + k u``
``first_point``       output   the first reading after a reversal differs systematically
===================== ======== ==============================================================

Effects are named on the command line as ``NAME[:OPTION]`` (``reversible:monotone``).  Each effect's class
carries what the rest of the program asks of it -- its options, what a run must record
(:attr:`Effect.must_record`), how the inversion takes it (:attr:`Effect.inversion`) -- so adding one is its
module and one line in :data:`EFFECT_CLASSES`.
"""

from __future__ import annotations

from typing import Any, Iterable

from ..errors import IdentifyError
from ..registry import ByName
from .ambient_drift import AmbientDrift
from .base import (INPUT, OUTPUT, SENSOR, Columns, Context, Effect, EffectNotApplicable, EffectNotIdentifiable)
from .baseline_drift import BaselineDrift
from .creep import Creep
from .first_point import FirstPoint
from .gain_drift import GainDrift
from .interaction import Interaction
from .joule_power import JoulePower
from .reversible import Reversible
from .sensor_nonlinearity import SensorNonlinearity
from .thermal_lag import ThermalLag

#: The effects, in the diagnosis library's order, which is also the order the input stage transforms the
#: heater voltage in (thermal lag, ambient drift, interaction): the registry (one line per effect).
EFFECT_CLASSES: tuple[type[Effect], ...] = (ThermalLag, BaselineDrift, AmbientDrift, GainDrift, JoulePower, Creep,
                                            SensorNonlinearity, Reversible, Interaction, FirstPoint)
#: The effects by name (:data:`EFFECT_CLASSES`, read at each use).
EFFECTS: ByName[type[Effect]] = ByName(lambda: EFFECT_CLASSES)


def spellings() -> str:
    """Every effect as ``--with`` accepts it (``name`` or ``name[:option]``), comma-separated, from the registry."""
    return ", ".join(f"{n}[:{'|'.join(cls.options)}]" if cls.options else n for n, cls in EFFECTS.items())


def _unknown(name: str) -> IdentifyError:
    return IdentifyError(f"unknown effect {name!r}; the known effects are {', '.join(EFFECTS)}")


def make_effect(spec: str) -> Effect:
    """An unfitted effect from ``NAME[:OPTION]``."""
    name, _, option = spec.strip().partition(":")
    if name not in EFFECTS:
        raise _unknown(name)
    if option:
        allowed = EFFECTS[name].options
        if option not in allowed:
            what = f"options {', '.join(allowed)}" if allowed else "no options"
            raise IdentifyError(f"effect {name!r} has {what}, not {option!r}")
        return EFFECTS[name](**{option: True})
    return EFFECTS[name]()


def parse_effects(specs: str | Iterable[str] | None) -> list[Effect]:
    """Unfitted effects from ``"a,b:opt"`` or a list of such strings (each name once); [] for None or ''."""
    if specs is None:
        return []
    items = specs.split(",") if isinstance(specs, str) else [s for spec in specs for s in spec.split(",")]
    effects = [make_effect(s) for s in items if s.strip()]
    names = [e.name for e in effects]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise IdentifyError(f"effect {', '.join(twice)} given twice")
    return effects


def effect_from_dict(data: Any) -> Effect:
    """A fitted effect from its stored form ``{"name": ..., "params": {...}}``."""
    if not isinstance(data, dict) or "name" not in data or not isinstance(data.get("params"), dict):
        raise IdentifyError('each effect must be an object {"name": ..., "params": {...}}')
    name = data["name"]
    if name not in EFFECTS:
        raise _unknown(str(name))
    return EFFECTS[name](data["params"])


def effect_to_dict(effect: Effect) -> dict[str, Any]:
    """The stored form of a fitted effect."""
    if not effect.fitted:
        raise IdentifyError(f"effect {effect.name!r} is not fitted")
    return {"name": effect.name, "params": effect.params}


def pipeline_order(effects: Iterable[Effect]) -> list[Effect]:
    """``effects`` in the order they act: the input stage (in :data:`EFFECT_CLASSES`' order: thermal lag,
    ambient drift, interaction), the output stage, the sensor stage."""
    effects = list(effects)
    rank = {INPUT: 0, OUTPUT: 1, SENSOR: 2}
    order = {cls.name: k for k, cls in enumerate(EFFECT_CLASSES)}

    def key(e: Effect) -> tuple[int, int]:
        return rank[e.stage], order.get(e.name, len(order)) if e.stage == INPUT else 0

    return sorted(effects, key=key)


__all__ = [
    "EFFECTS",
    "EFFECT_CLASSES",
    "INPUT",
    "OUTPUT",
    "SENSOR",
    "Columns",
    "Context",
    "Effect",
    "EffectNotApplicable",
    "EffectNotIdentifiable",
    "effect_from_dict",
    "effect_to_dict",
    "make_effect",
    "parse_effects",
    "pipeline_order",
    "spellings",
]
