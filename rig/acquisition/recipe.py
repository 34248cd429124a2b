"""How a new session wants to be identified: the recipe ``rig acquire`` records with it.

``rig identify SESSION`` uses the recorded recipe for every setting it is
not given (``--method``, ``--levels``, ``--v-min``/``--v-max``,
``--thermal-term``, ``--with``), so that the model a plan was designed for
is the one a user gets without knowing the plan.

The default (:func:`default_recipe`) is derived from what the run
acquires, by rules the documentation states, and nothing else:

* the grid: the one the excitation was built on (none for a file of
  set-points without ``--levels``: ``rig identify`` then needs ``--levels``);
* the method: ``ls`` -- on the damped oscillation it is the paper's
  least squares on its square design, and it takes any other input history;
  no documented rule makes another method the default for any sequence;
* the effects: none.  ``damped+check`` is an identification run that *can*
  tell effects apart, but which effects a sample shows is what ``rig
  diagnose`` finds out, so none is assumed;
* the thermal term: as the damped oscillation was run (with or without its
  thermal point: without it every input sits on a wall, where ``c_d v`` is
  an affine function of the diagonal cells and cannot be identified); on
  for every other input, as ``rig identify`` does by default.

``rig acquire --identify-with METHOD[:EFFECT,...]`` records another method
and effects (:func:`given_recipe`), checked before the rig is touched.
"""

from __future__ import annotations

import dataclasses

from sessions import ExcitationRecord, IdentifyRecipe

from .errors import AcquisitionError

#: The method a recipe names unless told otherwise (``rig identify``'s own default).
DEFAULT_METHOD = "ls"

_WHY = {
    "damped": "ls on the damped oscillation's own grid, the paper's square design",
    "damped+check": "ls on its grid, no effects: damped+check can tell effects apart, but which ones the sample "
                    "shows is for rig diagnose to say",
    "random": "ls on its grid (ls takes any input history)",
    "check": "ls on its grid (ls takes any input history)",
    "file": "ls on its grid (ls takes any input history)",
}


def default_recipe(record: ExcitationRecord) -> IdentifyRecipe:
    """The recipe of a run of ``record`` (the excitation ``rig acquire`` is about to apply): see the module doc."""
    thermal = record.thermal_term if record.kind == "damped" else True
    why = _WHY.get(record.kind, "ls on its grid (ls takes any input history)")
    if record.kind == "damped" and not record.thermal_term:
        why += ", without the thermal term (the run has no thermal point)"
    if record.levels is None:
        why = "ls (ls takes any input history); no grid is recorded, so rig identify needs --levels"
    return IdentifyRecipe(method=DEFAULT_METHOD, levels=record.levels, v_min=record.v_min, v_max=record.v_max,
                          effects=(), thermal_term=thermal, reason=f"rig acquire default for a {record.kind} run: {why}")


def parse_identify_with(text: str) -> tuple[str, tuple[str, ...]]:
    """``METHOD[:EFFECT,...]`` as ``(method, effects)``; an effect keeps its option (``reversible:monotone``)."""
    method, colon, rest = text.partition(":")
    method = method.strip()
    effects = tuple(e.strip() for e in rest.split(",")) if colon else ()
    if not method or "" in effects:
        raise AcquisitionError(f"--identify-with {text!r}: expected METHOD[:EFFECT,...], e.g. ls, smooth_nn or "
                               "ls:thermal_lag,creep")
    return method, effects


def given_recipe(text: str, record: ExcitationRecord) -> IdentifyRecipe:
    """The default recipe of ``record`` with the method and effects of ``--identify-with TEXT``, checked as
    far as can be before the run: a known method that applies to this sequence, known effects it can fit."""
    from identify.effects import parse_effects
    from identify.methods import METHODS

    method, effects = parse_identify_with(text)
    if method not in METHODS:
        raise AcquisitionError(f"--identify-with {text!r}: unknown method {method!r}; choose from "
                               f"{', '.join(METHODS)}")
    cls = METHODS[method]
    if cls.needs_curves:
        raise AcquisitionError(f"--identify-with {method}: identifies from first-order reversal curves (FORC data), "
                               "which rig acquire does not record; use ls or smooth_nn")
    if cls.needs_square and record.kind != "damped":
        raise AcquisitionError(f"--identify-with {method}: needs the square damped-oscillation design, and this run "
                               f"is {record.kind}; use ls or smooth_nn")
    if effects:
        if cls.needs_square:
            raise AcquisitionError(f"--identify-with {text!r}: {method} needs the square damped-oscillation design, "
                                   "which has no room for effect terms; fit effects with ls or smooth_nn")
        from identify import IdentifyError

        try:
            parse_effects(effects)  # unknown names, options or repeats: one line, before the rig is touched
        except IdentifyError as exc:
            raise AcquisitionError(f"--identify-with {text!r}: {exc}") from None
    base = default_recipe(record)
    return dataclasses.replace(base, method=method, effects=effects,
                               reason=f"rig acquire --identify-with {text.strip()}")
