"""Benchmarks of issue 8: the fast path against the dense reference (``rig bench``).

* :mod:`benchmarks.cases` -- the simulated problems;
* :mod:`benchmarks.worker` -- one measurement, run in a fresh process;
* :mod:`benchmarks.runner` -- every (case, method), both solvers, and the comparison.
"""
