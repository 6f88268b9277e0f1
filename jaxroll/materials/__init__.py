"""Viscoelastic materials, and their identification from raw DMA data.

* :mod:`~jaxroll.materials.material`: the models (standard linear solid, generalized Maxwell),
  temperature shifts (WLF, Arrhenius) and ``G*(omega)`` with its derived moduli;
* :mod:`~jaxroll.materials.read`: multi-temperature DMA frequency sweeps from instrument files,
  master curves already shifted, shift-factor files, Prony tables and isochronal temperature
  sweeps;
* :mod:`~jaxroll.materials.shift`: time-temperature superposition, shift laws, master curve;
* :mod:`~jaxroll.materials.prony`: Prony series fitted to a master curve;
* :mod:`~jaxroll.materials.export`: Abaqus / ANSYS decks and jaxroll's material JSON.

All SI: angular frequency [rad/s], shear moduli [Pa], temperatures [K], times [s].
"""

from .material import (
    GAS_CONSTANT,
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
from .read import DMASweeps, read_dma_sweeps, read_isochronal, read_master_curve, read_prony_table, read_shift_factors
from .checks import check_sweeps
from .shift import MasterCurve, ShiftFactors, ShiftFit, fit_arrhenius, fit_shift_factors, fit_wlf, loss_artifacts, master_curve
from .prony import PronyFit, fit_prony, instrument_weights, prony_moduli
from .export import load_material, save_material, write_abaqus, write_ansys

__all__ = [
    "GAS_CONSTANT", "AbstractMaterial", "AbstractShift", "Arrhenius", "AtTemperature", "GeneralizedMaxwell",
    "StandardLinearSolid", "WLF", "at_temperature", "complex_modulus", "glassy_modulus", "loss_modulus",
    "relaxation_modulus", "relaxed_modulus", "shift_factor", "storage_modulus", "tan_delta",
    "DMASweeps", "read_dma_sweeps", "read_master_curve", "read_prony_table", "read_shift_factors", "read_isochronal", "check_sweeps",
    "MasterCurve", "ShiftFactors", "ShiftFit", "fit_arrhenius", "fit_shift_factors", "fit_wlf", "loss_artifacts",
    "master_curve",
    "PronyFit", "fit_prony", "instrument_weights", "prony_moduli",
    "load_material", "save_material", "write_abaqus", "write_ansys",
]
