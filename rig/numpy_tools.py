"""numpy's test and Fortran-wrapper tools, kept out of a command's start-up.

numpy imports its submodules on first use, but scipy (1.15 and later)
imports its vendored ``array_api_compat``, whose numpy namespace is a copy
of ``numpy``'s made by ``from numpy import *``: that imports every public
submodule, among them ``numpy.f2py`` (which imports ``charset_normalizer``)
and ``numpy.testing`` (``unittest``, ``importlib.metadata``, ``email``) --
about 0.1 s of CPU that every command paid and none uses.  No setting of
scipy's turns the copy off, and the order of the imports does not matter:
``from numpy import *`` asks for each name.

:func:`defer_numpy_tools`, called before a command's module (and with it
scipy) is imported, registers those two as lazy modules
(:class:`importlib.util.LazyLoader`): the names exist, and a module runs
its code on first use of one of its attributes.
"""

from __future__ import annotations

import importlib.util
import sys

#: numpy's submodules that no command uses at run time.
DEFERRED = ("numpy.f2py", "numpy.testing")


def defer_numpy_tools() -> None:
    """Register :data:`DEFERRED` as lazy modules, unless scipy or the module is already imported."""
    if "scipy" in sys.modules:
        return
    import numpy

    for name in DEFERRED:
        if name in sys.modules:
            continue
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            continue
        spec.loader = importlib.util.LazyLoader(spec.loader)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        setattr(numpy, name.rpartition(".")[2], module)
