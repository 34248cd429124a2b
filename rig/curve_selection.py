"""``--curves even|odd|all``: which curves of a run a command fits or checks.

Curves are numbered from 0 in the order they were measured (a FORC file's
order), so ``even`` is curves 0, 2, 4, ... and ``odd`` 1, 3, 5, ...  The
selection picks *measured points*; every applied point still sets the
memory state of the points after it, whatever is selected.  With
``--measurements M``, the M points are drawn from the selected curves.
"""

from __future__ import annotations

import numpy as np

from sessions.recording import Recording

from .errors import UserError

#: The values of ``--curves``.
CURVE_CHOICES = ("all", "even", "odd")


def selected_rows(data: Recording, which: str) -> np.ndarray:
    """The measured rows of ``data`` on the selected curves, sorted.

    ``all`` is every measured row (curves or not); ``even``/``odd`` need a
    run with curves and at least one measured point on them.
    """
    rows = data.measured_rows
    if which == "all":
        return rows
    if which not in CURVE_CHOICES:
        raise UserError(f"--curves {which}: choose from {', '.join(CURVE_CHOICES)}")
    if data.curves is None:
        raise UserError(
            f"{data.path}: holds no curves; --curves {which} applies to runs made of curves "
            "(a FORC measurement: rig import --format micromag)"
        )
    c = data.curves[rows]
    keep = (c >= 0) & (c % 2 == (0 if which == "even" else 1))
    if not np.any(keep):
        raise UserError(f"{data.path}: no measured point lies on the {which}-numbered curves")
    return rows[keep]
