"""One thread for the LAPACK under JAX's CPU kernels (SciPy's bundled OpenBLAS).

JAX's CPU LAPACK kernels (``jnp.linalg.solve``, ``lu``, ... inside compiled programs: the dense
line-window solver, the preconditioners) call the LAPACK that SciPy ships, and so do SciPy's
least-squares solvers that the fits run on the host. jaxroll's matrices are small (at most a few
hundred rows), where OpenBLAS's threads only wait, and they wait by spinning: two processes on 2
cores, each with OpenBLAS's default of one thread per core, starve each other. Measured on 2
cores (benchmarks/LOG.md, "OpenBLAS threads"): the reduced cylinder fit of
``tests/test_fit_unbiased.py`` took 15.0 s wall / 25.3 s CPU alone and 605 s in each of two
concurrent processes; with this module's limit, 11.9 s / 16.6 s alone and 17-19 s in each of two.

So jaxroll sets SciPy's OpenBLAS to :data:`DEFAULT_THREADS` thread (through threadpoolctl):
at import where SciPy's LAPACK is loaded already, else right after it loads (a one-shot import
hook for ``scipy.linalg.cython_lapack``, the module JAX loads it through: ``import jaxroll``
itself does not load SciPy, 0.27 s, which a process running stored programs never needs),
unless ``JAXROLL_LAPACK_THREADS`` says otherwise (a count, or ``0``/``off``: leave it alone) or
``OPENBLAS_NUM_THREADS`` is set (the user chose). NumPy's own OpenBLAS (``np.dot``
on large arrays) is not touched. Where SciPy links a shared BLAS (a conda or system install: no
library inside SciPy's folders) nothing is changed either.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import os
import sys
from pathlib import Path

#: SciPy's OpenBLAS threads set at import (see the module docstring)
DEFAULT_THREADS = 1
#: Environment variable: a thread count for SciPy's OpenBLAS, or 0/off to leave it as it is
ENV = "JAXROLL_LAPACK_THREADS"
_OFF = ("0", "off", "false", "no", "default")
#: the module through which JAX's CPU kernels (and SciPy's solvers) load SciPy's LAPACK
LAPACK_MODULE = "scipy.linalg.cython_lapack"


def requested_threads(environ=os.environ) -> int | None:
    """The thread count to set (``None``: leave SciPy's OpenBLAS alone): :data:`ENV` if set,
    else :data:`DEFAULT_THREADS` unless ``OPENBLAS_NUM_THREADS`` is set. ``ValueError`` for a
    value of :data:`ENV` that is neither a positive count nor an off word."""
    value = environ.get(ENV, "").strip().lower()
    if not value:
        return None if "OPENBLAS_NUM_THREADS" in environ else DEFAULT_THREADS
    if value in _OFF:
        return None
    if not value.isdigit():
        raise ValueError(f"{ENV} must be a positive thread count or one of {', '.join(_OFF)}; got {value!r}")
    return int(value)


def limit_lapack_threads(environ=os.environ) -> list[tuple[str, int]]:
    """Set SciPy's bundled OpenBLAS to :func:`requested_threads`; returns ``(library path,
    threads)`` of every library changed (empty where nothing was)."""
    n = requested_threads(environ)
    if n is None:
        return []
    import scipy
    import scipy.linalg.cython_lapack  # noqa: F401  (SciPy's LAPACK: the one JAX's kernels call)
    from threadpoolctl import ThreadpoolController

    home = Path(scipy.__file__).resolve().parent
    folders = (home, home.parent / "scipy.libs")  # the wheel's own library folders (Linux, macOS, Windows)
    changed = []
    for lib in ThreadpoolController().select(internal_api="openblas").lib_controllers:
        path = Path(lib.filepath).resolve()
        if any(folder in path.parents for folder in folders):
            lib.set_num_threads(n)
            changed.append((str(path), n))
    return changed


def limit_when_loaded(environ=os.environ) -> None:
    """:func:`limit_lapack_threads` now if SciPy's LAPACK is loaded, else once it is (a finder
    at the head of ``sys.meta_path`` that removes itself at its first use). Nothing where
    :func:`requested_threads` says so."""
    if requested_threads(environ) is None:
        return
    if LAPACK_MODULE in sys.modules:
        limit_lapack_threads(environ)
    elif not any(isinstance(f, _LimitAfterLoad) for f in sys.meta_path):
        sys.meta_path.insert(0, _LimitAfterLoad(environ))


class _LimitAfterLoad(importlib.abc.MetaPathFinder):
    """Finds :data:`LAPACK_MODULE` as the other finders do, with a loader that runs
    :func:`limit_lapack_threads` after the module has loaded; leaves ``sys.meta_path`` at once."""

    def __init__(self, environ):
        self.environ = environ

    def find_spec(self, name, path=None, target=None):
        if name != LAPACK_MODULE:
            return None
        if self in sys.meta_path:
            sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None:
            spec.loader = _Then(spec.loader, lambda: limit_lapack_threads(self.environ))
        return spec


class _Then(importlib.abc.Loader):
    """``loader``, then ``after()`` once the module has executed."""

    def __init__(self, loader, after):
        self.loader, self.after = loader, after

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module):
        self.loader.exec_module(module)
        self.after()
