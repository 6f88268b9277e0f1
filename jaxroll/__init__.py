"""jaxroll: differentiable viscoelastic rolling resistance of rigid spheres and cylinders on
viscoelastic layers of finite thickness.

Importing jaxroll enables JAX's float64 mode (see ``jaxroll._numerics``) and JAX's persistent
compilation cache in the user's cache directory, ``~/.cache/jaxroll/jax`` (environment variable
``JAXROLL_COMPILATION_CACHE``: ``0`` switches it off, a path moves it; see
``jaxroll._compilation_cache``).
"""

from . import _numerics  # noqa: F401  (enables float64 first)
from . import _compilation_cache

_compilation_cache.enable()

# --- material (G*(omega)) ---------------------------------------------------------------
from .material import (
    AbstractMaterial,
    AbstractShift,
    Arrhenius,
    AtTemperature,
    GeneralizedMaxwell,
    StandardLinearSolid,
    WLF,
    at_temperature,
    complex_modulus,
    glassy_modulus,
    loss_modulus,
    relaxation_modulus,
    relaxed_modulus,
    shift_factor,
    storage_modulus,
    tan_delta,
)

# --- layer transfer (T(q)) ----------------------------------------------------------------
from .layer import Layer, shear_wave_speed, surface_compliance

# --- special functions, pressure, direct series, contact, references (added per module) ---
from . import reference, special  # noqa: F401  (special: importable as jaxroll.special)
from .reference import (
    ExactCylinder,
    HertzSphere,
    exact_cylinder_halfspace,
    exact_cylinder_halfspace_dimensionless,
    hertz_cylinder,
    hertz_cylinder_pressure,
    hertz_sphere,
    persson_cylinder_halfspace,
    persson_sphere_halfspace,
    thin_layer_cylinder,
    thin_layer_cylinder_pressure,
)
from .contact_size import contact_radius, estimate_contact_size, jaffar_coefficients
from .pressure import pressure_profile, pressure_transform
from .direct import QuadratureSettings
from . import contact, cylinder, direct, slices, sphere3d  # noqa: F401  (the engines, as modules)

# --- methods, grids, results and the front doors ------------------------------------------
from .grids import AutoGrid, FixedGrid, memory_budget
from .methods import AbstractMethod, Direct, DirectElastic, Full, Slices
from .result import RESULTS, RollingResult, SolverError, ValidityWarning
from .rolling import rolling_resistance, rolling_resistance_grid
from .sweep import DEFAULT_CHUNK_SIZE, Grid, sweep, sweep_mesh
from .fit import DataWarning, DMAData, FitResult, IdentifiabilityWarning, MisfitWarning, RollingData, fit_material, read_dma_csv, read_rolling_csv
from . import mastercurve  # noqa: F401  (raw multi-temperature DMA -> master curve -> Prony/WLF)
from .mastercurve import (DMASweeps, MasterCurve, PronyFit, ShiftFactors, ShiftFit, fit_arrhenius, fit_prony,  # noqa: F401
                          fit_shift_factors, fit_wlf, load_material, loss_artifacts, master_curve, read_dma_sweeps,  # noqa: F401
                          save_material, write_abaqus, write_ansys, ResistanceMap, resistance_map)  # noqa: F401

__version__ = "0.1.0"
