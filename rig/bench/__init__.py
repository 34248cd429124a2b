"""What ``rig bench`` runs: the fast path against the dense reference, on simulated problems (issue 8).

* :mod:`rig.bench.cases` -- the simulated problems;
* :mod:`rig.bench.worker` -- one measurement, run in a fresh process (``python -m rig.bench.worker``);
* :mod:`rig.bench.runner` -- every (case, method), both solvers, and the comparison.

Part of the installed package because ``rig bench`` needs it; the timing
scripts in the repository's ``benchmarks/`` directory are not installed.
"""
