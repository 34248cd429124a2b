"""How many BLAS threads a fit uses: one for a small problem, the library's default for a large one.

A fit at L = 30 does dense products on matrices of a few hundred rows.
Splitting those across threads costs more than it gains, and on a shared
two-core machine it costs a great deal: ``smooth_nn`` at L = 30 took 117 ms
per fit with OpenBLAS's default threads against 20 ms single-threaded, and
50 times longer under load (the threads wait on each other while other
processes hold the cores).  So a problem with at most
:data:`SMALL_PARAMETERS` parameters is solved with one BLAS thread
(``threadpoolctl``), a larger one with the library's own setting.

The choice is the program's default only: when the user has set
``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS`` or ``MKL_NUM_THREADS``
(``rig bench --threads N`` does), that setting is left alone.  Limits nest:
inside a limited section (a joint fit calling its method many times) the
inner calls cost nothing.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager

#: Largest problem (parameters P: cells, bias, thermal term) solved single-threaded by default:
#: L = 63 (2,018 parameters), where ``smooth_nn``'s dense normal equations end.  At L = 30 one thread
#: is 1.4-50x faster than two on the 2-core development machine (docs/results, rig time).
SMALL_PARAMETERS = 2100
#: Environment variables through which a user chooses the BLAS threads himself.
USER_SETTINGS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

_lock = threading.Lock()
_depth = 0


def user_chose_threads() -> bool:
    """Whether the environment sets the BLAS threads explicitly (then it is obeyed)."""
    return any(os.environ.get(name, "").strip() for name in USER_SETTINGS)


def single_threaded(parameters: int) -> bool:
    """Whether a problem of ``parameters`` parameters runs on one BLAS thread by default."""
    return parameters <= SMALL_PARAMETERS and not user_chose_threads()


@contextmanager
def blas_threads_for(parameters: int) -> Iterator[None]:
    """Run the body with one BLAS thread when the problem is small (see the module docstring).

    ``parameters``: the problem's size ``P``.  Nested uses inside a limited
    section do nothing (the outer limit holds).
    """
    global _depth
    with _lock:
        inside = _depth > 0
        if not inside and single_threaded(parameters):
            _depth += 1
            limiting = True
        else:
            limiting = False
    if not limiting:
        yield
        return
    try:
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1, user_api="blas"):
            yield
    finally:
        with _lock:
            _depth -= 1
