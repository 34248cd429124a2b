"""The ``rig`` side of the gap diagnosis: recorded runs in, reports and figures out.

* :mod:`~rig.diagnosis.loading` -- sessions (or CSV traces) as runs, with their checks;
* :mod:`~rig.diagnosis.report` -- the ``--json`` object and the readable report;
* :mod:`~rig.diagnosis.simulate` -- identification and check runs on the simulated bench;
* :mod:`~rig.diagnosis.demo` -- :func:`diagnose_simulated`, a whole diagnosis in one call.

The numerics are in :mod:`identify.diagnosis`; the figures in :mod:`rig.plots.diagnosis`.
"""
