"""Material identification from measured rolling resistance (and optionally DMA points):
:func:`fit_material` with its data objects :class:`RollingData` / :class:`DMAData` and readers.
"""

from ..io import DataWarning
from .fit import (DMAData, FitResult, IdentifiabilityWarning, MisfitWarning, RollingData, fit_material, read_dma_csv,
                  read_rolling_csv)

__all__ = ["DMAData", "DataWarning", "FitResult", "IdentifiabilityWarning", "MisfitWarning", "RollingData",
           "fit_material", "read_dma_csv", "read_rolling_csv"]
