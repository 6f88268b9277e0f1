"""jaxroll: differentiable viscoelastic rolling resistance of rigid spheres and cylinders on
viscoelastic layers of finite thickness.

Importing jaxroll enables JAX's float64 mode (see ``jaxroll._numerics``) and JAX's persistent
compilation cache in the user's cache directory, ``~/.cache/jaxroll/jax`` (environment variable
``JAXROLL_COMPILATION_CACHE``: ``0`` switches it off, a path moves it; see
``jaxroll._compilation_cache``). Imported before JAX with that cache on, it also sets
``TF_CPP_MIN_LOG_LEVEL=3`` when that is unset: XLA's C++ log would otherwise print three false
"could lead to execution errors such as SIGILL" lines (ERROR level) for every program loaded from
the cache on some x86 processors. Level 3 hides XLA's other C++ errors too (JAX itself sets level
1), also in the subprocesses that inherit the environment; ``TF_CPP_MIN_LOG_LEVEL=1`` or ``0``
before ``import jaxroll`` keeps them.

It also sets SciPy's bundled OpenBLAS, under JAX's CPU LAPACK kernels, to one thread
(``jaxroll._threads``: its threads spin-wait on jaxroll's small matrices; two processes on 2 cores
ran a fit 35x slower each). ``JAXROLL_LAPACK_THREADS=off`` (or a count), or an
``OPENBLAS_NUM_THREADS`` of the user's, keeps the user's setting.
"""

import os as _os
import sys as _sys
import typing as _typing

# the level is read once, when JAX loads XLA; "0", "off", ... switch the cache off
# (jaxroll._compilation_cache._OFF, not imported here: it imports JAX)
if "jax" not in _sys.modules and _os.environ.get("JAXROLL_COMPILATION_CACHE", "").strip().lower() not in (
        "0", "off", "false", "no"):
    _os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "3")

from . import _numerics  # noqa: F401  (enables float64 first)
from . import _compilation_cache

_compilation_cache.enable()

from . import _threads

_threads.limit_when_loaded()  # one thread for SciPy's OpenBLAS, once it loads: see jaxroll._threads

# --- materials (G*(omega)) and the layer ---------------------------------------------------
from .materials.material import (
    WLF,
    Arrhenius,
    GeneralizedMaxwell,
    StandardLinearSolid,
    at_temperature,
    complex_modulus,
)
from .engines.layer import Layer
from .engines.stack import HalfSpace, Ply, Stack

# --- methods, grids, results and the front doors ------------------------------------------
from .grids import AutoGrid, FixedGrid
from .methods import Direct, DirectElastic, Full, Slices
from ._numerics import PlausibilityWarning
from .geometry import Geometry
from .result import RESULTS, GridSolution, RollingResult, SolverError, ValidityWarning
from .rolling import rolling_resistance, rolling_resistance_grid
from ._xla_options import compiler_options
from .sweep import Grid, sweep, sweep_mesh  # (eager: the name sweep is both a module and a function)

# --- identification: DMA -> master curve -> Prony, and fits to rolling data ----------------
from .materials import fit_prony, fit_shift_factors, fit_wlf, load_material, master_curve, read_dma_sweeps, save_material

# --- subpackages and modules reachable as attributes ---------------------------------------
from . import contact, engines, grids, materials, methods, reference  # noqa: E402

#: Public names imported on first use (module ``__getattr__``): the maps, the fits, the conveyor
#: front end, the command line and the data sets, which a rolling-resistance call does not need
#: (a shorter ``import jaxroll``; benchmarks/LOG.md). name -> (module, attribute or None for the
#: module itself)
_LAZY = {
    "ResistanceMap": (".maps", "ResistanceMap"), "resistance_map": (".maps", "resistance_map"),
    "DataWarning": (".io", "DataWarning"),
    **{n: (".identify.fit", n) for n in ("DMAData", "FitResult", "IdentifiabilityWarning", "MisfitWarning",
                                         "RollingData", "fit_material")},
    **{n: (f".{n}", None) for n in ("apps", "conveyor", "datasets", "identify", "io")},
}


if _typing.TYPE_CHECKING:  # the same names for static readers (type checkers, IDEs, the API reference's mkdocstrings)
    from . import apps, conveyor, datasets, identify, io
    from .identify.fit import DMAData, FitResult, IdentifiabilityWarning, MisfitWarning, RollingData, fit_material
    from .io import DataWarning
    from .maps import ResistanceMap, resistance_map


def __getattr__(name):
    if name not in _LAZY:
        raise AttributeError(f"module 'jaxroll' has no attribute {name!r}")
    import importlib

    module, attribute = _LAZY[name]
    module = importlib.import_module(module, __name__)
    value = module if attribute is None else getattr(module, attribute)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


#: the package version (the one source: pyproject.toml reads it)
__version__ = "0.1.0"

__all__ = [
    # materials and layer
    "StandardLinearSolid", "GeneralizedMaxwell", "WLF", "Arrhenius", "at_temperature", "complex_modulus", "Layer",
    "Ply", "Stack", "HalfSpace",
    # methods and grids
    "Full", "Direct", "DirectElastic", "Slices", "AutoGrid", "FixedGrid",
    # front doors and results
    "rolling_resistance", "rolling_resistance_grid", "sweep", "sweep_mesh", "Grid", "resistance_map",
    "ResistanceMap", "RollingResult", "GridSolution", "RESULTS", "Geometry", "SolverError", "ValidityWarning",
    "PlausibilityWarning", "compiler_options",
    # identification
    "read_dma_sweeps", "fit_shift_factors", "fit_wlf", "master_curve", "fit_prony", "save_material",
    "load_material", "fit_material", "RollingData", "DMAData", "FitResult",
    "DataWarning", "IdentifiabilityWarning", "MisfitWarning",
    # subpackages
    "apps", "contact", "conveyor", "datasets", "engines", "grids", "identify", "io", "materials", "methods", "reference",
]
