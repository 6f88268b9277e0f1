"""Differentiable steady-state rolling contact on a viscoelastic surface (physics-free solver).

One solver for a rigid profile pressed on a surface whose compliance is a (generally
non-symmetric) convolution: the 1D line of a rolling cylinder (plane strain) and the 2D grid
of a rolling sphere use the same code; only the grid dimension differs. The modules follow the
solver's pipeline:

* :mod:`~jaxroll.contact.operator`: compliance kernels (periodic alias sums) and the windowed
  Toeplitz operator applied by FFT, with the Fourier convention of the library;
* :mod:`~jaxroll.contact.system`: the scaled equality-constrained system of a contact set;
* :mod:`~jaxroll.contact.linear`: linear solver objects (:class:`GMRES`, :class:`Dense`);
* :mod:`~jaxroll.contact.precondition`: the circulant preconditioner with block elimination;
* :mod:`~jaxroll.contact.active_set`: the primal-dual active-set iteration;
* :mod:`~jaxroll.contact.smoothing`: the smoothed contact edge (damped Newton on a soft minimum);
* :mod:`~jaxroll.contact.solve`: the front door :func:`solve_contact`, its solution and warm
  starts, and the implicit differentiation on the converged set.
"""

from .active_set import LOOSE_LINEAR_RTOL, active_set_loop, find_contact_set
from .linear import GMRES, AbstractLinearSolver, Dense
from .operator import (
    WindowedCompliance,
    WindowKernel,
    circulant_window_apply,
    embedding_size,
    fold_offsets,
    periodic_kernel,
    periodic_offsets,
    periodic_window_kernel,
    toeplitz_operator,
    windowed_compliance,
)
from .precondition import CirculantPreconditioner
from .smoothing import edge_gap_scale
from .solve import SAVED_FOR_DERIVATIVES, ContactSolution, WarmStart, solve_contact
from .system import ContactSystem

__all__ = [
    "ContactSolution",
    "WindowedCompliance",
    "periodic_kernel",
    "windowed_compliance",
    "solve_contact",
    "WarmStart",
    "WindowKernel",
    "active_set_loop",
    "find_contact_set",
    "periodic_window_kernel",
    "periodic_offsets",
    "toeplitz_operator",
    "embedding_size",
    "fold_offsets",
    "circulant_window_apply",
    "edge_gap_scale",
    "AbstractLinearSolver",
    "GMRES",
    "Dense",
    "CirculantPreconditioner",
    "ContactSystem",
    "LOOSE_LINEAR_RTOL",
    "SAVED_FOR_DERIVATIVES",
]
