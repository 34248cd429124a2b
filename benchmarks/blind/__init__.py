"""Blind generators of unmodelled effects, each written by a separate author from ``SPEC.md`` alone.

:mod:`~benchmarks.blind.base` is the base device they share (equation (22) on its grid, exactly what the
model represents); each sub-package adds the mechanisms its author wrote without reading the diagnosis,
the other generators, or the project's own withheld-forms generator (``benchmarks/withheld``).
"""
