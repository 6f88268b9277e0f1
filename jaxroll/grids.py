"""Computational grids of the full and slice models: explicit (:class:`FixedGrid`) or sized from
the inputs (:class:`AutoGrid`), and the rules that size them.

A grid is the discretisation of the layer surface: square cells of side ``spacing`` [m]
carrying a piecewise-constant pressure, a square *window* of ``window`` cells per side around
the roller where the pressure may be non-zero, and the surface period (``period`` [m]: a
periodic train of rollers a period apart, as in [ZG]) with, in 3D, the Fourier cut-off
``n_terms`` of the periodic compliance.

Static capacity apart from traced values: array sizes (window cells, period cells, Fourier
terms) must be known when a program is traced, while physical values (speed, load, material
parameters) are traced under ``jit``/``vmap``/``grad``. A :class:`FixedGrid` is absolute and
the same for every point of a batch; an :class:`AutoGrid` is sized only from concrete values
(``method.resolve(...)`` turns it into the :class:`FixedGrid` covering a whole envelope of loads
and speeds), and a front door called with traced inputs and an :class:`AutoGrid` raises rather
than guessing.

The sizing rules (one home for each):

* **counting size** (full models, :func:`counting_size`): the relaxed contact size
  (:func:`jaxroll.engines.contact_size.estimate_contact_size`), or where the material is much
  stiffer at the rolling frequency (cold or fast: a broad spectrum near its glassy end) a
  multiple of the dynamic size (:func:`jaxroll.engines.contact_size.dynamic_contact_size`,
  ``|G*|`` at ``omega = V/a``) that keeps the solved contact within the error tables'
  calibration. The rules round it down onto a ladder of ratio 2^(1/8) below the relaxed size.
* **sphere** (full 3D model): cell ``a = r/c`` with ``r`` the counting size and ``c`` cells per
  radius by the regime of every point (:func:`regime`: zeta = V tau/a for a standard linear solid, from the
  loss compliance for any material, and the breadth of the loss), :func:`sphere_cells_per_radius`:
  the fewest cells whose measured error envelope (:data:`SPHERE_ERROR`) is <= 0.5 % -- 12 at
  zeta >= 0.32, 16 for a broad spectrum near the peak, 20 at 0.1-0.32, 24 at 0.03-0.1, 32 at
  0.01-0.03, 48 below (the cap: up to 1.3 % there, measured). On a finite layer the envelope is
  also the thin-layer table's (:data:`THIN_ERROR`, by ``r/H``): 16-20 cells at ``r/H`` = 0.5-1,
  32-48 from 2; and at least ``2 r/H`` (the compliance kernel is only ~H wide); window
  ``2 ceil(1.25 r_max/a) + 1`` cells.
  :class:`~jaxroll.DirectElastic` (a static pressure) keeps ``c = 12``. Default: an infinite
  layer (``period=None``, the aperiodic kernel of :mod:`jaxroll.engines.aperiodic`). With
  ``period="auto"``: ``Lx >= 20 max(r, V t_max)``, ``Ly >= 20 r`` in powers of two of cells
  (``t_max`` the material's longest retardation time), ``Lx`` capped at 2^16 cells; Fourier
  cut-off ``n_terms`` = the larger cell count.
* **line**: cell ``a/c`` with ``a`` the counting half-width (full 2D cylinder) or the relaxed
  one (slices). The full 2D cylinder (it reports the dissipation form): ``c`` by the regime,
  :func:`cylinder_cells_per_radius` (on a half-space 12 at zeta >= 1, 25 at 0.01-1 or for
  a broad spectrum near the peak, 100-200 below; the envelope :data:`LINE_ERROR` against the
  exact half-space cylinder <= 0.5 %; on a finite layer also :data:`THIN_ERROR`, by ``a/H``: up to
  400 on thin layers at low zeta). The slices of PD/PP/SP
  (the moment form): ``c`` by the speed, :func:`line_cells_per_radius` (25 cells for
  ``0.03 <= V tau/a0 <= 30``, 128 down to 3e-3, 192 below, 50 up to 300, 100 above). Both: at
  least ``2 a/H``; window ``2 ceil(3 a_max/dx)`` cells. Default: an infinite layer. With
  ``period="auto"``: ``L >= 20 max(4 a, V t_max)`` (the elastic log-kernel interaction of
  periodic images tilts the pressure: at ``V tau = a0``, ``L = 20 a0`` gives -0.76 % in R_r,
  ``80 a0`` 0.0 %), capped at 2^21 cells.

The full models report :func:`full_model_value` (the dissipation form, blended toward the
midpoint of both forms at zeta < 5e-3) with ``truncation`` = :func:`full_model_error`: twice
the measured envelope at the grid's cells, the point's regime and the layer's ``a/H``, and at
least the share of the moment-dissipation gap the value may be off where the envelope does not
bound the error (docs/validation.md sec. 3).
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _compilation_cache
from ._numerics import as_float
from .engines.contact_size import dynamic_contact_size, estimate_contact_size

__all__ = ["AutoGrid", "FixedGrid", "PERIOD_FACTOR", "union"]

#: The period must exceed ``PERIOD_FACTOR max(contact size, V t_max)`` for the layer to recover
#: between passes (docs/design.md sec. 2: measured on the exact 2D solution).
PERIOD_FACTOR = 20.0
MAX_SPHERE_CELLS = 2**16  # the memory budget (check_memory) is the real limit
MAX_LINE_CELLS = 2**21
SPHERE_CELLS_PER_RADIUS = 12
SPHERE_WINDOW_RADII = 1.25
LINE_WINDOW_RADII = 3.0


def _concrete_float(name, x):
    if isinstance(x, jax.core.Tracer):
        raise ValueError(f"FixedGrid.{name} must be a concrete number (a grid is static configuration)")
    if isinstance(x, (str, bytes)) or np.ndim(x) != 0:
        raise ValueError(f"FixedGrid.{name} must be a number; got {x!r}")
    v = float(x)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"FixedGrid.{name} must be positive and finite; got {v}")
    return v


def _even_cells(L, dx):
    n = max(2, int(round(L / dx)))
    return n + n % 2


#: Working memory per 3D Fourier mode of the periodic kernel [bytes] (see FixedGrid.memory_estimate).
BYTES_PER_MODE = 100


#: Fraction of the smallest memory headroom that one model evaluation may plan for: the
#: estimate of :meth:`FixedGrid.memory_estimate` is approximate (XLA's temporaries, the
#: process's other arrays), so half leaves room for its error.
MEMORY_FRACTION = 0.5

#: Where the memory limits are read (module attributes, so that tests can point them elsewhere).
PROC = Path("/proc")
CGROUP = Path("/sys/fs/cgroup")

#: A cgroup v1 limit at or above this is "no limit" (the kernel writes ~2^63).
_NO_LIMIT = 2**60


def _read_int(path) -> int | None:
    """The integer in a one-line file, ``None`` if absent, unreadable or ``max``."""
    try:
        text = Path(path).read_text().split()[0]
    except (OSError, IndexError):
        return None
    return int(text) if text.isdigit() else None


def _available_memory():
    """``MemAvailable`` of ``/proc/meminfo`` [bytes] (``None`` where unknown)."""
    try:
        with open(PROC / "meminfo") as fh:
            return next(int(line.split()[1]) * 1024 for line in fh if line.startswith("MemAvailable:"))
    except (OSError, StopIteration, ValueError, IndexError):
        return None


def _address_space_headroom():
    """The soft address-space limit (``RLIMIT_AS``, ``ulimit -v``) minus this process's virtual
    size (``VmSize`` of ``/proc/self/status``) [bytes]; ``None`` without a limit."""
    try:
        import resource
    except ImportError:  # not a POSIX system
        return None
    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    if soft == resource.RLIM_INFINITY or soft < 0:
        return None
    used = 0
    try:
        with open(PROC / "self" / "status") as fh:
            used = next(int(line.split()[1]) * 1024 for line in fh if line.startswith("VmSize:"))
    except (OSError, StopIteration, ValueError, IndexError):
        pass
    return max(soft - used, 0)


def _cgroup_headroom():
    """The cgroup (container) memory limit minus the cgroup's usage [bytes], the smallest over
    the process's own cgroup (``/proc/self/cgroup``) and the root of the mount; ``None``
    without a limit. cgroup v2: ``memory.max - memory.current``; v1 (under ``memory/``):
    ``memory.limit_in_bytes - memory.usage_in_bytes``."""
    v2, v1 = [CGROUP], [CGROUP / "memory"]
    try:
        for line in (PROC / "self" / "cgroup").read_text().splitlines():
            _, controllers, path = line.split(":", 2)
            if controllers == "":
                v2.insert(0, CGROUP / path.strip().lstrip("/"))
            elif "memory" in controllers.split(","):
                v1.insert(0, CGROUP / "memory" / path.strip().lstrip("/"))
    except (OSError, ValueError):
        pass
    room = []
    for d, (limit_file, usage_file) in [(d, ("memory.max", "memory.current")) for d in v2] + [
            (d, ("memory.limit_in_bytes", "memory.usage_in_bytes")) for d in v1]:
        limit = _read_int(d / limit_file)
        if limit is not None and limit < _NO_LIMIT:
            room.append(max(limit - (_read_int(d / usage_file) or 0), 0))
    return min(room) if room else None


def memory_limit() -> tuple[int, str]:
    """The working memory [bytes] one model evaluation may plan for, and where it comes from.

    ``JAXROLL_MEMORY_BUDGET`` (bytes, or with a suffix ``MB``/``GB``) if set; else
    :data:`MEMORY_FRACTION` (half) of the smallest of: the memory available now
    (``MemAvailable``), the address-space limit left to this process (``RLIMIT_AS`` minus its
    virtual size) and the cgroup (container) memory limit left (v2 ``memory.max`` minus
    ``memory.current``, v1 ``memory.limit_in_bytes`` minus ``memory.usage_in_bytes``), taken as
    8 GiB where none is readable."""
    text = os.environ.get("JAXROLL_MEMORY_BUDGET")
    if text:
        m = re.fullmatch(r"\s*([0-9.eE+-]+)\s*([KMGT]?)(i?B)?\s*", text, re.IGNORECASE)
        try:
            return int(float(m.group(1)) * 1024 ** "_KMGT".index(m.group(2).upper() or "_")), "JAXROLL_MEMORY_BUDGET"
        except (AttributeError, ValueError):
            raise ValueError(f"JAXROLL_MEMORY_BUDGET must be a size in bytes (or 8GB, 500MB); got {text!r}") from None
    limits = [(_available_memory(), "the available memory (MemAvailable)"),
              (_address_space_headroom(), "the address-space limit left (RLIMIT_AS, ulimit -v)"),
              (_cgroup_headroom(), "the cgroup memory limit left (container)")]
    known = [(b, src) for b, src in limits if b is not None]
    if not known:
        return int(MEMORY_FRACTION * 8 * 2**30), "half of 8 GiB (no memory limit readable)"
    headroom, src = min(known, key=lambda k: k[0])
    return int(MEMORY_FRACTION * headroom), f"half of {src}, {headroom / 2**30:.1f} GiB"


def memory_budget() -> int:
    """The most working memory [bytes] one model evaluation may plan for (see
    :func:`memory_limit`, which also names its source)."""
    return memory_limit()[0]


def check_memory(grid: "FixedGrid", ndim: int, what: str) -> None:
    """``ValueError``, one line (what was asked, what it needs, the budget and its source, what
    to change), when ``grid`` needs more working memory than :func:`memory_limit` allows."""
    need = grid.memory_estimate(ndim)
    budget, source = memory_limit()
    if need > budget:
        spacing = "traced" if isinstance(grid.spacing, jax.core.Tracer) else f"{float(grid.spacing):.3g} m"
        described = f"FixedGrid(spacing={spacing}, window={grid.window}, n_cells={grid.n_cells})"
        raise ValueError(
            f"{what} on {described} needs about {need / 2**30:.1f} GiB of working memory, above the budget of "
            f"{budget / 2**30:.1f} GiB ({source}): use a shorter period (an automatic period grows like "
            f"20 x V x the longest retardation time), a smaller n_terms, a coarser spacing, or the direct method "
            f"(no grid); or set JAXROLL_MEMORY_BUDGET (e.g. 8GB) if more memory is free.")


class FixedGrid(eqx.Module):
    """An explicit grid: the same discretisation for every point of a batch.

    Args:
        spacing: cell size ``a`` [m] (square cells; the paper's 3D grid: 0.25 mm).
        window: cells per side of the pressure window centred under the roller (paper: 41 in
            3D). The contact must stay inside it (else ``RESULTS.window_too_small``).
        period: period of the surface [m]: a number (``Lx = Ly`` for spheres), ``(Lx, Ly)``
            (spheres), or ``None`` for an infinite layer. With a period, the cell size is
            adjusted to hold a whole, even number of cells per period.
        n_terms: Fourier cut-off ``|m_x|, |m_y| <= n_terms`` of the periodic 3D compliance
            (paper: 500); default the larger period cell count. Spheres only.

    ``spacing`` and ``period`` are traced values inside the front doors' compiled programs
    (a new cell size reuses the compiled program); ``window``, ``n_terms`` and the period cell
    counts ``n_cells`` are static.
    """

    spacing: float | jax.Array
    period: tuple | None
    window: int = eqx.field(static=True)
    n_terms: int | None = eqx.field(static=True)
    n_cells: tuple | None = eqx.field(static=True)

    def __init__(self, spacing, window, period=None, n_terms=None):
        dx = _concrete_float("spacing", spacing)
        if isinstance(window, (bool, np.bool_)) or not isinstance(window, (int, np.integer)) or window < 2:
            raise ValueError(f"FixedGrid.window must be an integer number of cells >= 2; got {window!r}")
        if n_terms is not None and (isinstance(n_terms, bool) or not isinstance(n_terms, (int, np.integer))
                                    or n_terms < 1):
            raise ValueError(f"FixedGrid.n_terms must be a positive integer or None; got {n_terms!r}")
        if period is None:
            self.period, self.n_cells = None, None
            if n_terms is not None:
                raise ValueError("FixedGrid.n_terms is the cut-off of a periodic compliance: give a period")
        else:
            if isinstance(period, (tuple, list)):
                if len(period) != 2:
                    raise ValueError(f"FixedGrid.period must be a number or a pair (Lx, Ly); got {period!r}")
                Lx, Ly = (_concrete_float("period", p) for p in period)
            else:
                Lx = Ly = _concrete_float("period", period)
            Nx = _even_cells(Lx, dx)
            dx = Lx / Nx  # a whole number of cells per period
            Ny = _even_cells(Ly, dx)
            self.period, self.n_cells = (Lx, Ny * dx), (Nx, Ny)
            if window > min(Nx, Ny):
                raise ValueError(f"FixedGrid: the window ({window} cells) is wider than the period "
                                 f"({min(Nx, Ny)} cells)")
        self.spacing = dx
        self.window = int(window)
        self.n_terms = None if n_terms is None else int(n_terms)

    @property
    def periodic(self) -> bool:
        return self.period is not None

    def terms(self) -> int:
        """The 3D Fourier cut-off along the longer period: ``n_terms`` or its cell count."""
        return max(self.n_cells) if self.n_terms is None else self.n_terms

    def axis_terms(self, n_terms=None) -> tuple:
        """The 3D Fourier cut-off per axis ``(n_x, n_y)``: one cut-off wavelength
        ``max(Lx, Ly)/n_terms`` on both axes (``n_terms`` default :meth:`terms`), so the mode
        count grows like ``Lx Ly``, not like the square of the longer period."""
        n = self.terms() if n_terms is None else int(n_terms)
        big = max(self.n_cells)
        return tuple(max(1, int(round(n * N / big))) for N in self.n_cells)

    def memory_estimate(self, ndim) -> int:
        """Working memory [bytes] of one model evaluation on this grid (``ndim = 2``: the 3D
        periodic kernel; 1: a plane-strain line), before anything is allocated. Calibrated on
        jax 0.9.2 CPU (peak resident memory above the process baseline, the compiled program's
        temporary buffers): ~100 B per 3D Fourier mode and 64 B per period cell, plus the contact
        solver's Krylov basis (``restart + 1`` window vectors of the largest basis its default GMRES
        builds, twice for the adjoint solve), and in 3D the preconditioner's symbol
        (:func:`jaxroll.engines.sphere3d._with_symbol`: four images of ``T_1 S``, or one image of
        ``T S`` at a time for stacks and layers with inertia, and two complex multipliers on the
        ``~2W x W`` half-spectrum of the embedding, ~128 B per window cell)."""
        from .contact.linear import FALLBACK_RESTART, RESTART_PLAIN, RESTART_PRECONDITIONED

        restart = max(RESTART_PRECONDITIONED, FALLBACK_RESTART) if ndim == 2 else RESTART_PLAIN
        symbol = 128 * self.window ** 2 if ndim == 2 else 0
        return self._kernel_memory(ndim) + 16 * (restart + 1) * self.window ** ndim + symbol

    def _kernel_memory(self, ndim) -> int:
        """The compliance kernel's share of :meth:`memory_estimate` [bytes]."""
        if self.period is None:
            # the quadrature nodes of jaxroll.engines.aperiodic; in 3D the y-integrals (two W-column
            # tables per x node) and one chunk of the node tensor
            from .engines import aperiodic

            wq = aperiodic.W_CUT_SURFACE if ndim == 2 else aperiodic.W_TAIL_LINE
            nodes = aperiodic.fourier_rule(self.window, wq).w.size
            if ndim == 2:
                return (64 * (2 * self.window) ** 2 + 48 * nodes * self.window
                        + 400 * aperiodic.SURFACE_CHUNK * nodes)
            return 64 * 2 * self.window + 200 * nodes
        cells = int(np.prod(self.n_cells)) if ndim == 2 else self.n_cells[0]
        if ndim == 2:
            nx, ny = self.axis_terms()
            return BYTES_PER_MODE * (2 * nx + 1) * (ny + 1) + 64 * cells
        return 64 * cells

    def dynamic(self) -> "FixedGrid":
        """The grid with ``spacing`` and ``period`` as float64 arrays (traced by ``jit``)."""
        return jax.tree_util.tree_map(lambda v: jnp.asarray(v, jnp.float64), self)

    def period_ok(self, contact_size, memory_length, ndim):
        """Whether the period exceeds ``PERIOD_FACTOR max(contact_size, memory_length)`` along x
        (and ``PERIOD_FACTOR contact_size`` along y in 3D); True on an infinite layer."""
        if self.period is None:
            return jnp.asarray(True)
        Lx, Ly = self.period
        ok = Lx >= PERIOD_FACTOR * jnp.maximum(contact_size, memory_length)
        return ok & (Ly >= PERIOD_FACTOR * contact_size) if ndim == 2 else ok


class AutoGrid(eqx.Module):
    """A grid sized from the inputs (concrete values only), by the rules of the module docstring.

    Args:
        cells_per_radius: cells per estimated contact radius (sphere) or half-width
            (cylinder, slices); ``None``: the model's rule (full models: by the regime, 12..48
            cells for spheres, 12..200 for cylinders; slices 25..192 by speed).
        window_radii: half-width of the pressure window in estimated contact radii (``None``:
            1.25 for spheres, 3 for lines).
        period: ``None`` (default: an infinite layer, the aperiodic influence coefficients of
            :mod:`jaxroll.engines.aperiodic`; memory and time follow the contact, not ``V t_max``),
            ``"auto"`` (a periodic surface long enough for the layer to recover,
            ``>= period_factor max(contact size, V t_max)``), or a period [m] (or ``(Lx, Ly)``).
        period_factor: see ``period="auto"``.
        n_terms: 3D Fourier cut-off (``None``: the larger period cell count).

    Under ``jit``/``vmap``/``grad`` the inputs are traced and an AutoGrid cannot be sized: call
    ``method.resolve(material, layer, radius=..., loads=..., speeds=..., geometry=...)`` first
    (or give a :class:`FixedGrid`).
    """

    cells_per_radius: int | None = eqx.field(static=True, default=None)
    window_radii: float | None = eqx.field(static=True, default=None)
    period: float | tuple | str | None = eqx.field(static=True, default=None)
    period_factor: float = eqx.field(static=True, default=PERIOD_FACTOR)
    n_terms: int | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        if self.cells_per_radius is not None and (not isinstance(self.cells_per_radius, (int, np.integer))
                                                  or self.cells_per_radius < 1):
            raise ValueError(f"AutoGrid.cells_per_radius must be a positive integer; got {self.cells_per_radius!r}")
        if self.window_radii is not None and not (isinstance(self.window_radii, (int, float))
                                                  and self.window_radii > 0):
            raise ValueError(f"AutoGrid.window_radii must be a positive number; got {self.window_radii!r}")
        if isinstance(self.period, str) and self.period != "auto":
            raise ValueError(f"AutoGrid.period must be 'auto', a length in m, a pair, or None; got {self.period!r}")
        if not (self.period_factor > 0):
            raise ValueError("AutoGrid.period_factor must be positive")

    # ---- the rules ------------------------------------------------------------------------------

    def sphere(self, material, layer, radius, loads, speeds, *, model="full") -> FixedGrid:
        """The :class:`FixedGrid` of the full 3D model covering every load and speed given
        (concrete arrays). ``model="full"``: cells per radius by the regime of every point,
        :func:`sphere_cells_per_radius`; ``"static"`` (the static pressure of
        :class:`~jaxroll.DirectElastic`): :data:`SPHERE_CELLS_PER_RADIUS`."""
        loads, speeds = _envelope(loads, speeds)
        r, w, V = _rule_sizes(material, layer, radius, loads, speeds, "sphere", model == "full")
        H = float(np.asarray(layer.H))
        cpr = self.cells_per_radius
        if cpr is None and model == "full":
            cpr = _regime_cells(material, layer, V, r, "sphere")  # each point's own (see _sphere_grid)
        elif cpr is None:
            cpr = max(SPHERE_CELLS_PER_RADIUS, _cells(2.0 * r.max() / H) if math.isfinite(H) else 0)
        return self._sphere_grid(r, w, cpr, float(speeds.max()), material)

    def _sphere_grid(self, r, w, cpr, speed_max, material) -> FixedGrid:
        """The 3D grid of at least ``cpr`` cells per radius of ``r`` [m] (``cpr`` a number, or one
        per size: the cell is the finest any size asks for, ``min(r/cpr)``; the largest count on the
        smallest size, as before 2026-11-29, gave a table over 2.6e-4..7.4 m/s of a loss-dominated
        solid cells 2.6x finer than any of its points needs and a 347-cell window against 121),
        its window covering the largest window size of ``w`` [m], the automatic period long enough
        for ``speed_max`` [m/s]."""
        dx = float(np.min(np.asarray(r, float) / cpr))
        window = 2 * _cells((self.window_radii or SPHERE_WINDOW_RADII) * w.max() / dx) + 1
        period = self.period
        if isinstance(period, str):
            memory = speed_max * _longest_time(material)
            Nx = min(_next_pow2(max(self.period_factor * max(w.max(), memory) / dx, window)), MAX_SPHERE_CELLS)
            Ny = min(_next_pow2(max(self.period_factor * w.max() / dx, window)), MAX_SPHERE_CELLS)
            period = (Nx * dx, Ny * dx)
        return FixedGrid(dx, window, period=period, n_terms=self.n_terms)

    def line(self, material, layer, radius, loads, speeds, *, model="slices") -> FixedGrid:
        """The :class:`FixedGrid` of a plane-strain line covering every load per unit length
        and speed given (concrete arrays): ``model="full"``, the full 2D cylinder (it reports the
        dissipation form; cells by the regime of every point, :func:`cylinder_cells_per_radius`);
        ``"slices"``, the slices of PD/PP/SP with their middle-slice loads per unit length (they
        report the moment form; :func:`line_cells_per_radius`)."""
        loads, speeds = _envelope(loads, speeds)
        G0 = float(np.asarray(material.relaxed_modulus()))
        a0 = np.sqrt(loads * float(radius) / (np.pi * G0))  # relaxed Hertz half-width (E* = 4 G0)
        H = float(np.asarray(layer.H))
        cpr = self.cells_per_radius
        a, w, V = _rule_sizes(material, layer, radius, loads, speeds, "cylinder", model == "full")
        if cpr is None and model == "full":
            cpr = _regime_cells(material, layer, V, a, "cylinder")  # each point's own (see _line_grid)
        elif cpr is None:
            zeta = np.outer(speeds * _longest_time(material), 1.0 / a0)  # V tau / a0 over the envelope
            cpr = max(line_cells_per_radius(float(z)) for z in np.ravel(zeta))
            if math.isfinite(H):
                cpr = max(cpr, _cells(2.0 * a.max() / H))
        return self._line_grid(a, w, cpr, float(speeds.max()), material)

    def _line_grid(self, a, w, cpr, speed_max, material) -> FixedGrid:
        """The line grid of at least ``cpr`` cells per half-width of ``a`` [m] (a number, or one per
        half-width: ``min(a/cpr)``, as :meth:`_sphere_grid`), its window covering the largest
        window size of ``w`` [m], the automatic period long enough for ``speed_max`` [m/s]."""
        dx = float(np.min(np.asarray(a, float) / cpr))
        window = 2 * _cells((self.window_radii or LINE_WINDOW_RADII) * w.max() / dx)
        period = self.period
        if isinstance(period, str):
            L_need = self.period_factor * max(4.0 * w.max(), speed_max * _longest_time(material))
            period = min(_next_pow2(max(L_need / dx, 2 * window)), MAX_LINE_CELLS) * dx
        return FixedGrid(dx, window, period=period)

    # ---- per-regime buckets -----------------------------------------------------------------------

    def point_cells(self, material, layer, radius, loads, speeds, geometry) -> tuple:
        """``(cells, sizes, window sizes)``: for each point ``(loads[i], speeds[i])`` (concrete
        arrays of one length) the cells per counting contact radius (sphere) or half-width (cylinder) that
        the full model's rule asks for at that point alone (what :meth:`sphere` / :meth:`line`
        with ``model="full"`` give for ``loads=[P_i], speeds=[V_i]``: by the regime, at least
        ``2 r/H`` on a finite layer; ``cells_per_radius`` where given), and that size [m] as
        the rules round it (:func:`counting_size` on the ladder :data:`SIZE_LADDER`), with the
        size its window covers (:func:`_grid_sizes`). Host NumPy arrays."""
        loads = np.atleast_1d(np.asarray(loads, float)).ravel()
        speeds = np.broadcast_to(np.atleast_1d(np.asarray(speeds, float)).ravel(), loads.shape)
        _envelope(loads, speeds)
        r, w = _grid_sizes(material, layer, radius, loads, speeds, geometry)
        if self.cells_per_radius is not None:
            return np.full(r.shape, self.cells_per_radius), r, w
        return _regime_cells(material, layer, speeds, r, geometry), r, w

    def buckets(self, material, layer, radius, loads, speeds, geometry) -> list:
        """The points ``(loads[i], speeds[i])`` grouped by the grid the full model's rule asks
        for at each point alone (:meth:`point_cells`: its cells per radius and its estimated
        size): ``[(grid, indices), ...]``, coarsest class first. Each grid is that of every one
        of its points (an automatic period: long enough for the bucket's fastest point), so a
        batch solved per bucket gives the per-point numbers. Buckets of one class share the
        window (static) and differ only in the cell size (a traced value), hence one compiled
        program per class; a temperature x speed map at one load has one bucket per class."""
        cells, r, w = self.point_cells(material, layer, radius, loads, speeds, geometry)
        speeds = np.broadcast_to(np.atleast_1d(np.asarray(speeds, float)).ravel(), r.shape)
        build = self._sphere_grid if geometry == "sphere" else self._line_grid
        out = []
        for c, size in sorted(set(zip(cells.tolist(), r.tolist()))):
            idx = np.flatnonzero((cells == c) & (r == size))
            out.append((build(r[idx], w[idx], int(c), float(speeds[idx].max()), material), idx))
        return out


def line_cells_per_radius(zeta: float) -> int:
    """Cells per half-width giving <= 0.5 % error of the 2D moment form against the exact
    half-space cylinder (measured, f = 1, infinite layer): 25 cells err <= 0.5 % for
    0.03 <= V tau/a0 <= 30 (-2.2 % at 0.01, +1.5 % at 100); 128 cells: +0.06 % at 0.01, -0.31 % at
    3e-3, -0.81 % at 1e-3; 192 cells: -0.43 % at 1e-3; 50 cells: -0.1 % at 100, +0.65 % at 1000;
    100 cells: +0.2 % at 1000."""
    if zeta < 0.003:
        return 192
    if zeta < 0.03:
        return 128
    if zeta <= 30.0:
        return 25
    if zeta <= 300.0:
        return 50
    return 100


#: Regime nodes of the error tables: log10 of the regime zeta (:func:`regime_zeta`).
ERROR_LOG_ZETA = (-3.0, -2.5, -2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 3.0)

#: Cells per estimated contact radius of the columns of :data:`SPHERE_ERROR`.
SPHERE_ERROR_CELLS = (12, 16, 20, 24, 32, 48, 64)

#: Relative error [%] of the dissipation form of the full 3D model (infinite layer) by regime
#: (rows, :data:`ERROR_LOG_ZETA`) and cells per radius (columns): the envelope of the errors
#: measured by ``benchmarks/resistance_forms.py`` (sphere R = 2 cm, 100 and 30 N, half-space;
#: standard linear solids G0 = 3 MPa, tau = 0.25 s, f = 0.5, 1, 2, 3 at zeta = 2e-3..1e3 and the
#: weakly dispersive f = 0.1, 0.3 at zeta = 0.05..0.3, which err most just below the peak (f = 0.3
#: at zeta = 0.1: -0.58 % at 16 cells; not run at 64 cells, where the rows at zeta = 0.1 and
#: 0.3 repeat the 48-cell value), and two Prony series of 20 and 12 decades at 1e-6..1e3 m/s,
#: whose regime zeta is 1.0-1.2), each
#: against its value extrapolated to zero cell size from 20..64 cells (20..48 for f = 0.1, 0.3; a fit ``D + C c^-p``);
#: the Prony series' own envelope is :data:`SPHERE_BROAD_ERROR`. At zeta <= 3e-3 the
#: convergence is first order or slower, so the extrapolation there is uncertain (the
#: truncation also takes the moment-dissipation gap, which brackets it).
SPHERE_ERROR = (
    (2.41, 2.00, 1.62, 1.72, 1.31, 1.14, 0.93),
    (3.25, 2.79, 2.34, 2.37, 1.86, 1.58, 1.35),
    (1.63, 0.87, 0.51, 0.54, 0.25, 0.23, 0.20),
    (0.70, 0.60, 0.56, 0.43, 0.43, 0.32, 0.27),
    (0.75, 0.60, 0.46, 0.35, 0.26, 0.16, 0.16),
    (0.39, 0.28, 0.19, 0.15, 0.10, 0.06, 0.06),
    (0.45, 0.24, 0.18, 0.15, 0.11, 0.08, 0.07),
    (0.45, 0.24, 0.18, 0.15, 0.11, 0.08, 0.07),
    (0.14, 0.10, 0.08, 0.04, 0.02, 0.01, 0.01),
    (0.39, 0.25, 0.18, 0.18, 0.14, 0.12, 0.10),
    (0.39, 0.25, 0.18, 0.18, 0.14, 0.12, 0.10),
)

#: Cells per estimated half-width of the columns of :data:`LINE_ERROR`.
LINE_ERROR_CELLS = (12, 25, 50, 100, 200, 400)

#: Relative error [%] of the dissipation form of the full 2D cylinder (infinite layer) by regime
#: and cells per half-width, measured by ``benchmarks/resistance_forms.py`` (R = 2 cm,
#: 10 kN/m, half-space): the standard linear solids (f = 0.5, 1, 2, 3) against the exact
#: solution (the Prony series of :data:`SPHERE_ERROR` against 400-800 cells are
#: :data:`LINE_BROAD_ERROR`), and the weakly dispersive f = 0.1 and 0.3 at zeta = 0.05..0.3,
#: which err most just below the peak (-0.64 / -0.67 % at zeta = 0.1, 12 cells, against -0.26 %
#: for f = 1), and the strongly dispersive f = 10 at zeta = 1e-3..100, which errs most at
#: zeta = 0.3-0.5 (-0.84 / -0.69 % at 12 cells, so the rule takes 25 cells from zeta = 0.32 to 1);
#: rounded up, at least 0.01 %. On a half-space the error depends on zeta, f and the cells only
#: (the problem is self-similar in the load): f = 2 errs -0.28 % at zeta = 0.5, 12 cells, against
#: -0.11 % for f = 1 at 0.3.
LINE_ERROR = (
    (17.1, 7.5, 3.0, 1.0, 0.20, 0.04),
    (10.3, 3.6, 0.94, 0.10, 0.02, 0.01),
    (3.3, 0.35, 0.12, 0.04, 0.02, 0.01),
    (0.84, 0.30, 0.05, 0.03, 0.01, 0.01),
    (0.70, 0.26, 0.11, 0.05, 0.01, 0.01),
    (0.84, 0.27, 0.06, 0.02, 0.01, 0.01),
    (0.28, 0.14, 0.04, 0.01, 0.01, 0.01),
    (0.28, 0.04, 0.02, 0.01, 0.01, 0.01),
    (0.06, 0.02, 0.01, 0.01, 0.01, 0.01),
    (0.07, 0.02, 0.01, 0.01, 0.01, 0.01),
    (0.07, 0.01, 0.01, 0.01, 0.01, 0.01),
)

#: Regimes (zeta) where a broad spectrum's own envelope applies (:func:`dissipation_error`).
BROAD_ZETA = (0.3, 3.2)

#: Relative error [%] of the 3D dissipation form for a broad spectrum near the peak, by the
#: columns of :data:`SPHERE_ERROR`: the envelope of the two Prony series (20 and 12 decades,
#: regime zeta 1.0-1.2, breadth >= 0.8) at 1e-6..1e3 m/s, which err 2-3x more than the standard
#: linear solids there (the table's rows 1 and 3.16).
SPHERE_BROAD_ERROR = (1.14, 0.47, 0.37, 0.34, 0.28, 0.23, 0.20)

#: As :data:`SPHERE_BROAD_ERROR` for the 2D cylinder (columns of :data:`LINE_ERROR`).
LINE_BROAD_ERROR = (1.22, 0.28, 0.05, 0.02, 0.02, 0.01)

#: Contact size over layer thickness (the counting size over H) of the blocks of
#: :data:`THIN_ERROR`.
THIN_RATIOS = {"sphere": (0.2, 0.5, 1.0, 2.0, 3.5, 6.0, 10.0),
               "cylinder": (0.2, 0.35, 0.5, 1.0, 2.0, 3.5, 6.0, 10.0, 15.0)}

#: Smallest ratio of the solved contact size to the counting size in the calibration of
#: :data:`THIN_ERROR` (layers past its first block): between the thick and thin ranges the
#: estimate (the smaller of the Hertz and thin-layer sizes) overshoots the contact, and a glassy
#: contact is narrower still (cylinder, f = 3, a/H = 3.5, zeta = 100: 1.40 mm solved against
#: 3.41 mm); measured 0.30 (cylinder) and 0.49 (sphere).
THIN_CONTACT_RATIO = {"sphere": 0.48, "cylinder": 0.30}

#: Cells per estimated contact size of the columns of :data:`THIN_ERROR`.
THIN_CELLS = {"sphere": (12, 16, 20, 24, 32, 48), "cylinder": LINE_ERROR_CELLS}

#: Relative error [%] of the reported value of the full models on layers thinner than the
#: half-space tables' calibration, by contact size over thickness (blocks, :data:`THIN_RATIOS`),
#: regime (rows, :data:`ERROR_LOG_ZETA`) and cells per counting size (columns,
#: :data:`THIN_CELLS`): the envelope measured by ``benchmarks/thin_layer_error.py``
#: (incompressible layers; standard linear solids G0 = 3 MPa, tau = 0.25 s, cylinder f = 0.3, 1, 3,
#: 10, R = 2 cm, 10 kN/m; sphere f = 1, 3, R = 2 cm, 100 N; a broad spectrum near the peak reads
#: :data:`THIN_BROAD_ERROR` as well), each point against its dissipation form extrapolated to
#: zero cell size (a fit ``D + C c^-p``: cylinder from 100..1600 cells, sphere from 20..96), binned to the
#: nearest block and row, made non-increasing in the cells (the error is not monotone in the
#: cells at low zeta), rounded up; 100 where no converged reference exists (3D at zeta <= 3e-3
#: on layers from a/H = 3.5: the 96-cell value is 2-12 % off the extrapolation there, so the
#: point is never valid). The errors grow with a/H, most at low zeta (cylinder at zeta = 0.01 and
#: 25 cells: 1.3 % at a/H = 0.2, 82 % at 10): the contact edge of a thin layer is set by a kernel
#: only ~H wide. Compressible layers err less (nu = 0.4, a/H = 6, zeta = 0.01, 25 cells: 10 %
#: against 21 %; nu = 0.3, a/H = 15: 0.07 % at 30 cells against the Winkler foundation), so the
#: incompressible envelope is conservative for them.
THIN_ERROR = {
    "sphere": (
        (
            (6, 4.8, 3.9, 3.6, 2.7, 1.8),
            (0.51, 0.37, 0.29, 0.17, 0.17, 0.17),
            (1.5, 0.72, 0.33, 0.33, 0.016, 0.016),
            (0.64, 0.64, 0.6, 0.46, 0.4, 0.25),
            (0.74, 0.46, 0.34, 0.24, 0.19, 0.094),
            (0.38, 0.38, 0.23, 0.21, 0.14, 0.094),
            (0.41, 0.2, 0.18, 0.1, 0.064, 0.033),
            (0.46, 0.22, 0.16, 0.094, 0.058, 0.021),
            (0.44, 0.17, 0.14, 0.11, 0.055, 0.027),
            (0.39, 0.22, 0.14, 0.12, 0.063, 0.033),
            (0.42, 0.21, 0.14, 0.091, 0.058, 0.022),
        ),
        (
            (5.5, 4.6, 3.8, 2.8, 2.3, 1.5),
            (0.6, 0.44, 0.39, 0.15, 0.15, 0.15),
            (1.4, 0.71, 0.26, 0.21, 0.025, 0.018),
            (0.76, 0.76, 0.7, 0.62, 0.51, 0.38),
            (0.84, 0.51, 0.37, 0.25, 0.17, 0.083),
            (0.4, 0.38, 0.24, 0.23, 0.15, 0.11),
            (0.46, 0.26, 0.16, 0.1, 0.067, 0.031),
            (0.54, 0.29, 0.17, 0.099, 0.046, 0.022),
            (0.47, 0.22, 0.15, 0.15, 0.075, 0.043),
            (0.37, 0.31, 0.15, 0.13, 0.07, 0.036),
            (0.44, 0.35, 0.18, 0.18, 0.14, 0.082),
        ),
        (
            (8.4, 5.9, 5.3, 3.8, 2.9, 1.8),
            (2.5, 1.5, 1.5, 0.84, 0.45, 0.39),
            (0.45, 0.39, 0.21, 0.069, 0.069, 0.069),
            (1.5, 0.96, 0.85, 0.58, 0.34, 0.16),
            (1.2, 0.71, 0.61, 0.4, 0.19, 0.092),
            (0.97, 0.58, 0.32, 0.24, 0.16, 0.064),
            (0.65, 0.32, 0.22, 0.13, 0.06, 0.028),
            (0.5, 0.33, 0.22, 0.14, 0.089, 0.04),
            (0.64, 0.29, 0.19, 0.19, 0.092, 0.055),
            (0.53, 0.36, 0.21, 0.15, 0.096, 0.058),
            (0.55, 0.37, 0.2, 0.15, 0.11, 0.069),
        ),
        (
            (12, 9.4, 7.6, 5.3, 4.6, 2.8),
            (2.2, 0.93, 0.93, 0.93, 0.88, 0.88),
            (1.4, 1.4, 0.82, 0.82, 0.07, 0.07),
            (2.5, 1.4, 0.97, 0.74, 0.74, 0.37),
            (2.4, 1.1, 0.72, 0.4, 0.36, 0.16),
            (1.4, 0.99, 0.53, 0.48, 0.25, 0.12),
            (1.3, 0.62, 0.38, 0.37, 0.24, 0.15),
            (1.5, 0.41, 0.4, 0.28, 0.16, 0.089),
            (0.81, 0.59, 0.45, 0.25, 0.14, 0.058),
            (1.3, 0.51, 0.36, 0.32, 0.2, 0.13),
            (1.3, 0.5, 0.37, 0.33, 0.21, 0.14),
        ),
        (
            (18, 14, 12, 9.4, 7.9, 5),
            (2.3, 2.3, 2.1, 2.1, 2, 2),
            (5.8, 4.1, 1.5, 1.3, 0.57, 0.14),
            (1.3, 1.3, 1.3, 0.72, 0.49, 0.23),
            (2.6, 1.4, 1.3, 0.88, 0.66, 0.32),
            (1.5, 1.2, 0.77, 0.51, 0.29, 0.15),
            (1.9, 1.3, 0.7, 0.48, 0.29, 0.14),
            (2.1, 1.2, 0.73, 0.51, 0.31, 0.19),
            (1.9, 0.94, 0.64, 0.37, 0.22, 0.088),
            (1.7, 1, 0.68, 0.65, 0.4, 0.24),
            (1.6, 1.1, 0.68, 0.65, 0.39, 0.23),
        ),
        (
            (34, 26, 21, 17, 12, 7.6),
            (12, 8.9, 8.1, 6.8, 5.6, 4.1),
            (24, 14, 8.5, 5.1, 2.5, 0.79),
            (4.6, 0.81, 0.68, 0.68, 0.66, 0.45),
            (3, 2.3, 1.5, 1.2, 0.66, 0.32),
            (2.7, 1.8, 1.2, 0.82, 0.49, 0.23),
            (3.4, 1.9, 1.2, 0.83, 0.45, 0.19),
            (3.3, 1.6, 1.2, 0.79, 0.41, 0.2),
            (2.8, 1.9, 1.1, 0.73, 0.44, 0.2),
            (2.7, 1.7, 1.2, 0.71, 0.42, 0.17),
            (2.7, 1.7, 1.3, 0.71, 0.4, 0.17),
        ),
        (
            (90, 68, 55, 45, 33, 21),
            (57, 48, 39, 33, 26, 18),
            (88, 55, 35, 23, 11, 4),
            (20, 8, 3.8, 1.8, 0.51, 0.049),
            (5.5, 3.6, 2.8, 2.2, 1.3, 0.62),
            (7.7, 4.6, 2.9, 2.2, 1.3, 0.6),
            (7.6, 4.4, 2.9, 2.1, 1.3, 0.56),
            (7.6, 4.5, 2.9, 2, 1.2, 0.49),
            (7.3, 4.2, 2.8, 2, 1.1, 0.49),
            (7.1, 4.2, 2.7, 2, 1.1, 0.49),
            (7.1, 4.2, 2.7, 2, 1.1, 0.48),
        ),
    ),
    "cylinder": (
        (
            (1.2, 1.2, 1.2, 0.71, 0.34, 0.095),
            (4.9, 2.7, 0.24, 0.053, 0.041, 0.029),
            (2.9, 1.4, 0.08, 0.074, 0.018, 0.013),
            (0.73, 0.3, 0.11, 0.051, 0.024, 0.019),
            (1.5, 0.25, 0.11, 0.038, 0.013, 0.01),
            (0.75, 0.34, 0.027, 0.019, 0.01, 0.01),
            (0.32, 0.041, 0.022, 0.01, 0.01, 0.01),
            (0.35, 0.039, 0.017, 0.01, 0.01, 0.01),
            (0.18, 0.042, 0.01, 0.01, 0.01, 0.01),
            (0.16, 0.018, 0.011, 0.01, 0.01, 0.01),
            (0.18, 0.055, 0.015, 0.01, 0.01, 0.01),
        ),
        (
            (4, 0.9, 0.63, 0.63, 0.2, 0.068),
            (12, 1.8, 1.3, 0.094, 0.026, 0.022),
            (9, 0.53, 0.53, 0.16, 0.078, 0.01),
            (3.2, 0.62, 0.31, 0.098, 0.031, 0.01),
            (2.8, 0.44, 0.25, 0.066, 0.015, 0.015),
            (1.8, 0.38, 0.099, 0.01, 0.01, 0.01),
            (0.25, 0.19, 0.056, 0.011, 0.01, 0.01),
            (0.35, 0.096, 0.013, 0.01, 0.01, 0.01),
            (0.2, 0.031, 0.014, 0.01, 0.01, 0.01),
            (0.19, 0.054, 0.01, 0.01, 0.01, 0.01),
            (0.2, 0.065, 0.012, 0.01, 0.01, 0.01),
        ),
        (
            (2.5, 1.3, 0.83, 0.83, 0.38, 0.16),
            (5.8, 1.8, 0.94, 0.097, 0.052, 0.024),
            (3.7, 0.37, 0.37, 0.081, 0.021, 0.01),
            (0.99, 0.42, 0.11, 0.06, 0.016, 0.01),
            (1.4, 0.56, 0.14, 0.062, 0.017, 0.01),
            (1.3, 0.44, 0.11, 0.014, 0.01, 0.01),
            (0.33, 0.23, 0.032, 0.019, 0.01, 0.01),
            (0.43, 0.052, 0.025, 0.01, 0.01, 0.01),
            (0.24, 0.043, 0.015, 0.01, 0.01, 0.01),
            (0.3, 0.069, 0.01, 0.01, 0.01, 0.01),
            (0.34, 0.071, 0.02, 0.01, 0.01, 0.01),
        ),
        (
            (2.8, 1.8, 1.1, 1.1, 0.093, 0.093),
            (14, 2.5, 0.83, 0.18, 0.15, 0.014),
            (9.6, 0.41, 0.33, 0.33, 0.01, 0.01),
            (2.9, 0.66, 0.33, 0.33, 0.023, 0.01),
            (0.98, 0.84, 0.078, 0.061, 0.024, 0.01),
            (2.9, 0.68, 0.061, 0.019, 0.01, 0.01),
            (1.4, 0.37, 0.064, 0.021, 0.01, 0.01),
            (0.86, 0.25, 0.023, 0.01, 0.01, 0.01),
            (0.52, 0.098, 0.029, 0.01, 0.01, 0.01),
            (0.36, 0.11, 0.024, 0.011, 0.01, 0.01),
            (0.36, 0.14, 0.029, 0.01, 0.01, 0.01),
        ),
        (
            (3.3, 3.3, 2.6, 0.41, 0.41, 0.096),
            (18, 5.9, 1.6, 0.95, 0.071, 0.045),
            (12, 2.7, 0.75, 0.28, 0.057, 0.022),
            (0.4, 0.4, 0.27, 0.19, 0.024, 0.015),
            (2.9, 0.5, 0.24, 0.095, 0.03, 0.01),
            (3.1, 0.74, 0.26, 0.032, 0.013, 0.01),
            (1.5, 0.16, 0.15, 0.038, 0.014, 0.01),
            (1.3, 0.22, 0.032, 0.01, 0.01, 0.01),
            (0.58, 0.24, 0.036, 0.014, 0.01, 0.01),
            (0.52, 0.23, 0.043, 0.015, 0.01, 0.01),
            (0.51, 0.23, 0.044, 0.016, 0.01, 0.01),
        ),
        (
            (7.9, 1.9, 1.9, 1.9, 0.6, 0.17),
            (47, 13, 5, 0.18, 0.13, 0.036),
            (34, 4.8, 1.9, 0.17, 0.062, 0.032),
            (9.1, 0.66, 0.66, 0.2, 0.039, 0.01),
            (2.5, 0.61, 0.54, 0.16, 0.023, 0.018),
            (1.8, 0.61, 0.29, 0.075, 0.012, 0.012),
            (2.9, 0.38, 0.057, 0.044, 0.01, 0.01),
            (0.94, 0.34, 0.02, 0.02, 0.012, 0.01),
            (1.6, 0.29, 0.083, 0.02, 0.01, 0.01),
            (1.9, 0.31, 0.037, 0.021, 0.01, 0.01),
            (1.9, 0.32, 0.038, 0.023, 0.01, 0.01),
        ),
        (
            (29, 3, 3, 3, 0.71, 0.23),
            (150, 45, 13, 1.8, 0.53, 0.068),
            (110, 22, 4.1, 0.32, 0.096, 0.01),
            (25, 4.4, 1.9, 0.2, 0.095, 0.05),
            (5.3, 0.31, 0.22, 0.2, 0.01, 0.01),
            (2.2, 0.87, 0.23, 0.047, 0.01, 0.01),
            (2.4, 0.2, 0.14, 0.032, 0.013, 0.01),
            (2, 0.19, 0.091, 0.018, 0.01, 0.01),
            (0.98, 0.23, 0.058, 0.019, 0.01, 0.01),
            (2.6, 0.47, 0.11, 0.014, 0.01, 0.01),
            (2.6, 0.49, 0.12, 0.03, 0.01, 0.01),
        ),
        (
            (140, 16, 9.3, 9.3, 4, 0.59),
            (570, 170, 40, 7.3, 1.2, 0.21),
            (420, 83, 12, 1.6, 0.34, 0.03),
            (95, 15, 1.3, 0.14, 0.13, 0.043),
            (14, 4.2, 0.11, 0.11, 0.034, 0.01),
            (0.45, 0.21, 0.2, 0.028, 0.013, 0.01),
            (3, 0.34, 0.15, 0.042, 0.01, 0.01),
            (1.9, 0.22, 0.059, 0.012, 0.01, 0.01),
            (0.96, 0.23, 0.048, 0.016, 0.01, 0.01),
            (2.2, 0.49, 0.12, 0.018, 0.01, 0.01),
            (2.2, 0.5, 0.13, 0.035, 0.01, 0.01),
        ),
        (
            (350, 47, 28, 28, 11, 2.2),
            (1700, 510, 130, 24, 3.4, 0.48),
            (1300, 250, 38, 5.4, 0.62, 0.1),
            (290, 38, 4.9, 1.2, 0.074, 0.025),
            (37, 6.1, 0.39, 0.084, 0.04, 0.012),
            (12, 0.7, 0.044, 0.044, 0.01, 0.01),
            (2.3, 0.25, 0.099, 0.021, 0.01, 0.01),
            (1.9, 0.25, 0.055, 0.028, 0.01, 0.01),
            (0.96, 0.26, 0.057, 0.025, 0.01, 0.01),
            (1.2, 0.31, 0.055, 0.019, 0.01, 0.01),
            (1.2, 0.32, 0.055, 0.03, 0.01, 0.01),
        ),
    ),
}

#: Breadth (:func:`regime`) from which a spectrum reads :data:`THIN_BROAD_ERROR` in full (below it
#: in proportion): the error on thin layers does not fall with the breadth as on a half-space (a
#: 21-term Prony series at breadth 0.61, a/H = 3.4, zeta = 1, 25 cells: 1.03 % off, against
#: 0.77 % per unit breadth in the table).
THIN_BROAD_FULL = 0.5

#: Relative error [%] of the 2D model's reported value for a broad spectrum near the peak
#: (:data:`BROAD_ZETA`) on thin layers, from breadth :data:`THIN_BROAD_FULL` (below it in
#: proportion to the breadth), by the blocks of :data:`THIN_RATIOS`
#: (rows) and :data:`THIN_CELLS` (columns): the Prony series of :data:`THIN_ERROR`'s calibration
#: (regime zeta 0.9-1.1, breadth ~1) at 1e-6..1e3 m/s, which errs up to 35x more than the
#: standard linear solids there (a/H = 15, 12 cells: 76 % against 2.2 %). The sphere's study has
#: no broad spectrum: its thin layers read the half-space's :data:`SPHERE_BROAD_ERROR`.
THIN_BROAD_ERROR = {
    "cylinder": (
        (0.48, 0.13, 0.03, 0.019, 0.01, 0.01),
        (0.59, 0.16, 0.092, 0.014, 0.01, 0.01),
        (0.5, 0.18, 0.042, 0.018, 0.01, 0.01),
        (0.76, 0.32, 0.054, 0.017, 0.01, 0.01),
        (2, 0.71, 0.11, 0.036, 0.01, 0.01),
        (3.1, 0.77, 0.16, 0.07, 0.025, 0.01),
        (11, 3, 0.8, 0.22, 0.057, 0.019),
        (32, 7.1, 2, 0.42, 0.12, 0.027),
        (76, 19, 4.8, 1.1, 0.26, 0.064),
    ),
}

#: Factor from the tables' measured envelope to the reported bound ``truncation``: points off the
#: tables' calibration (other f, zeta between rows, other spectra) erred up to 2x the envelope
#: before it took them in (docs/validation.md sec. 3).
ERROR_SAFETY = 2.0

#: Target relative error of the dissipation form that the automatic full-model grids are sized for.
TARGET_ERROR = 5e-3

#: Largest loss factor ``tan delta = G''/G'`` over a contact's frequencies that jaxroll's error
#: models were calibrated at (the full models' error tables and the direct method's estimate):
#: standard linear solids up to f = 10, whose loss factor peaks at ``f/(2 sqrt(1 + f))`` = 1.51,
#: and measured Prony spectra (the shipped material: 0.34). Beyond it
#: (:func:`loss_beyond_calibration`; rubbers reach f ~ 1e3, tan delta 15.8) the full models'
#: tables under-estimated their error (sphere, 30 mm layer, 10 mm/s: +1.3 % at f = 100 and
#: +2.8 % at f = 1000 against 32 cells, with a bound of 0.90 %), which then takes at least the
#: moment-dissipation gap (1.8 % and 4.3 % there); the direct method is not valid there.
CALIBRATED_TAN_DELTA = 1.6
#: Frequencies at which :func:`loss_beyond_calibration` reads the loss factor (log-spaced).
_LOSS_NODES = 9


#: How far below the contact's own frequency ``V/r`` the approximate methods (direct, slices) read
#: the loss factor (:func:`loss_beyond_calibration`'s ``below``): waves up to ten contact sizes
#: long carry part of the loss (the wake; on a half-space their weight falls off only linearly in
#: ``q``), and where the loss factor peaks there the rolling pressure is far from any stationary
#: one. SLS G0 = 3.21 MPa, tau = 85.8 ms, f = 146 on a 346 mm layer (R = 2 cm, 42.9 / 104 N) at
#: 6.13 m/s, above the R_r peak: tan delta 1.0-1.4 at ``V/r``, 6.0 a decade lower; the direct
#: method with the dynamic contact was valid with an estimate of 4.7 / 6.8 % and 18.5 / 26.6 %
#: low against the full 3D model (benchmarks/LOG.md, 2026-11-29). Materials whose loss factor
#: stays below :data:`CALIBRATED_TAN_DELTA` (every calibration material) are not affected.
APPROXIMATION_LONG_WAVES = 10.0


def loss_beyond_calibration(material, V, r_lo, r_hi, below: float = 1.0) -> jax.Array:
    """Whether the loss factor ``tan delta`` exceeds :data:`CALIBRATED_TAN_DELTA` anywhere over
    the frequencies a contact of size ``r_lo..r_hi`` [m] rolling at ``V`` [m/s] excites,
    ``V/(below r_hi) .. 10 V/r_lo`` (``False`` at ``V = 0``); ``below`` (static, >= 1): how far
    below the contact's frequency the band starts (:data:`APPROXIMATION_LONG_WAVES` for the
    approximate methods). Not differentiated. Jittable."""
    if not (isinstance(below, (int, float)) and below >= 1.0):
        raise ValueError(f"below must be a static number >= 1; got {below!r}")
    material, V, r_lo, r_hi = jax.lax.stop_gradient((material, V, r_lo, r_hi))
    moving = (V > 0) & (r_lo > 0)
    V = jnp.where(moving, V, 1.0)
    r_lo, r_hi = jnp.where(moving, r_lo, 1.0), jnp.where(moving, r_hi, 1.0)
    lo, hi = jnp.log(V / (below * r_hi)), jnp.log(10.0 * V / r_lo)
    nodes = _LOSS_NODES + int(round((_LOSS_NODES - 1) * math.log10(below)))  # the same density per decade
    omega = jnp.exp(lo[..., None] + (hi - lo)[..., None] * jnp.linspace(0.0, 1.0, nodes))
    G = material.complex_modulus(omega)
    return moving & jnp.any(jnp.imag(G) > CALIBRATED_TAN_DELTA * jnp.real(G), axis=-1)


#: Largest cells per radius the sphere rule asks for (the cost grows like its fourth power or
#: faster; at zeta <= 3e-3 even 64 cells leave ~1 %).
MAX_SPHERE_RULE_CELLS = 48

#: Below this regime zeta the truncation takes at least the moment-dissipation gap: there the
#: moment form is low and the dissipation form high (measured at every resolution, 2D and 3D,
#: zeta <= 3e-3), so the truth lies between them and the gap bounds the dissipation form's
#: error, where the table's 3D rows converge too slowly to be extrapolated reliably.
BRACKETING_ZETA = 5e-3


def regime(material, speed, size) -> tuple:
    """The regime of a rolling contact: ``(zeta, breadth)`` [-] at ``speed`` [m/s] with the
    estimated contact radius or half-width ``size`` [m], from the loss compliance
    ``J''(omega) = G''/|G*|^2`` at the contact frequency ``omega = V/a`` (central differences in
    ``ln omega``, step 0.05):

    * ``zeta = sqrt((1 - s)/(1 + s))`` with the slope ``s = d ln J''/d ln omega``: exactly
      ``V tau/a`` for the standard linear solid (its ``J''`` is a Debye peak at
      ``omega tau = 1``, ``s = (1 - (omega tau)^2)/(1 + (omega tau)^2)``). A broad Prony
      spectrum (a flat loss) sits near 1; a loss dominated by fast terms (rising ``J''``) is
      low-zeta, where the contact edge carries the dissipation.
    * ``breadth = 1 - b/(1 - s^2)`` with the curvature ``b = -d^2 ln J''/d(ln omega)^2``,
      clipped to [0, 1]: 0 for a single Debye peak (where ``b = 1 - s^2``), ~1 for a loss
      spread over decades (a Prony series of many terms).

    ``zeta`` is clipped to [1e-6, 1e6]; ``(1, 0)`` where there is no loss (elastic, ``V = 0``).
    Jittable."""
    h = 0.05
    w = jnp.asarray(speed, float) / jnp.asarray(size, float)
    G = jnp.stack([material.complex_modulus(w * math.exp(k * h)) for k in (-1, 0, 1)])
    loss = jnp.imag(G) / jnp.abs(G) ** 2
    ok = jnp.all(loss > 0, axis=0) & (w > 0)
    L = jnp.log(jnp.where(ok, loss, 1.0))
    s = jnp.clip((L[2] - L[0]) / (2 * h), -1.0 + 1e-12, 1.0 - 1e-12)
    b = -(L[2] - 2 * L[1] + L[0]) / h**2
    zeta = jnp.where(ok, jnp.clip(jnp.sqrt((1.0 - s) / (1.0 + s)), 1e-6, 1e6), 1.0)
    breadth = jnp.where(ok, jnp.clip(1.0 - b / (1.0 - s * s), 0.0, 1.0), 0.0)
    return zeta, breadth


def regime_zeta(material, speed, size) -> jax.Array:
    """The regime zeta of :func:`regime` (``V tau/a`` for the standard linear solid). Jittable."""
    return regime(material, speed, size)[0]


def dissipation_error(zeta, cells, geometry, breadth=0.0, thickness_ratio=0.0) -> jax.Array:
    """The measured error envelope [-, relative] of the reported value of the full model of
    ``geometry`` at regime ``zeta`` (:func:`regime_zeta`) with ``cells`` cells per estimated
    contact radius or half-width: :data:`SPHERE_ERROR` / :data:`LINE_ERROR`, the larger of the
    two rows around ``zeta`` (the error is not monotone between them), interpolated linearly in
    ``(log cells, log error)``; beyond the table's cells, second order below and first order
    above (conservative: measured 1.5-3 at zeta >= 0.01). A broad spectrum (``breadth`` of
    :func:`regime`) near the peak (:data:`BROAD_ZETA`) errs more than a single Debye peak: there
    the larger of the table and ``breadth`` times :data:`SPHERE_BROAD_ERROR` /
    :data:`LINE_BROAD_ERROR`. On a finite layer (``thickness_ratio`` = counting size / H > 0) the
    larger of that and the thin-layer envelope :data:`THIN_ERROR`: the largest of the four
    entries around ``(thickness_ratio, zeta)`` (ratios beyond the last block read the last two;
    a broad spectrum near the peak: also :data:`THIN_BROAD_ERROR`, times ``breadth`` /
    :data:`THIN_BROAD_FULL` below that breadth),
    and below the first block (a/H = 0.2) the half-space envelope moved toward the first block's
    in proportion to the ratio (the error at a/H = 0.1-0.2 exceeded the half-space envelope by up
    to 2.5x: cylinder, f = 3, zeta = 1e3, 12 cells, -0.18 % against 0.07 %). Jittable."""
    table, cols = (SPHERE_ERROR, SPHERE_ERROR_CELLS) if geometry == "sphere" else (LINE_ERROR, LINE_ERROR_CELLS)
    broad = jnp.log(jnp.asarray(SPHERE_BROAD_ERROR if geometry == "sphere" else LINE_BROAD_ERROR)) - jnp.log(100.0)
    logt = jnp.log(jnp.asarray(table)) - jnp.log(100.0)
    thin = jnp.log(jnp.asarray(THIN_ERROR[geometry])) - jnp.log(100.0)
    thin_broad = (jnp.log(jnp.asarray(THIN_BROAD_ERROR[geometry])) - jnp.log(100.0) if geometry in THIN_BROAD_ERROR
                  else jnp.full((len(THIN_RATIOS[geometry]), len(THIN_CELLS[geometry])), -jnp.inf))
    ratios = jnp.log(jnp.asarray(THIN_RATIOS[geometry]))
    logcols = jnp.log(jnp.asarray(cols, float))
    thin_logcols = jnp.log(jnp.asarray(THIN_CELLS[geometry], float))
    nodes = jnp.asarray(ERROR_LOG_ZETA)

    def bracket(grid, x):
        # the interval of a sorted grid that holds x (clipped to the grid): a search by comparison
        # with every node (tiny tables: no loop in the program)
        return jnp.clip(jnp.searchsorted(grid, x, side="right", method="compare_all") - 1, 0, grid.shape[0] - 2)

    def over_cells(column, logcols, logc):
        # jnp.interp's formula in (log cells, log error); beyond the columns second order below
        # and first order above
        k = jnp.clip(bracket(logcols, logc) + 1, 1, logcols.shape[0] - 1)
        rise = column[k] - column[k - 1]
        inside = column[k - 1] + ((logc - logcols[k - 1]) / (logcols[k] - logcols[k - 1])) * rise
        below = column[0] + 2.0 * (logcols[0] - logc)
        above = column[-1] + (logcols[-1] - logc)
        return jnp.where(logc < logcols[0], below, jnp.where(logc > logcols[-1], above, inside))

    def one(z, c, w, t):
        i = bracket(nodes, jnp.clip(jnp.log10(z), nodes[0], nodes[-1]))
        near_peak = (z >= BROAD_ZETA[0]) & (z <= BROAD_ZETA[1])
        column = jnp.maximum(jnp.maximum(logt[i], logt[i + 1]),
                             jnp.where(near_peak & (w > 0), broad + jnp.log(jnp.maximum(w, 1e-300)), -jnp.inf))
        j = bracket(ratios, jnp.log(jnp.maximum(t, 1e-300)))
        broad_thin = jnp.where(near_peak & (w > 0),
                               thin_broad + jnp.log(jnp.clip(w / THIN_BROAD_FULL, 1e-300, 1.0)), -jnp.inf)
        thin_column = jnp.maximum(jnp.maximum(thin[j, i], thin[j, i + 1]),
                                  jnp.maximum(thin[j + 1, i], thin[j + 1, i + 1]))
        thin_column = jnp.maximum(thin_column, jnp.maximum(broad_thin[j], broad_thin[j + 1]))
        logc = jnp.log(c)
        err = over_cells(column, logcols, logc)
        # thicker than the first block: from the half-space's envelope (t = 0) to the first block's,
        # linearly in t (in log error)
        first = over_cells(jnp.maximum(jnp.maximum(thin[0, i], thin[0, i + 1]), broad_thin[0]), thin_logcols, logc)
        share = jnp.clip(t / THIN_RATIOS[geometry][0], 0.0, 1.0)
        thin_err = jnp.where(t > THIN_RATIOS[geometry][0], over_cells(thin_column, thin_logcols, logc),
                             (1.0 - share) * err + share * first)
        return jnp.exp(jnp.maximum(err, thin_err))

    return jnp.vectorize(one)(jnp.asarray(zeta, float), jnp.asarray(cells, float), jnp.asarray(breadth, float),
                              jnp.asarray(thickness_ratio, float))


#: Regimes (zeta) over which the reported value moves from the dissipation form D (above) to
#: the midpoint of the moment form M and D (below), smoothly in log zeta: where M is low and D
#: high (:data:`BRACKETING_ZETA`) and both converge at first order or slower, the midpoint's
#: error is at most half their gap (2D, exact solution: at zeta = 1e-3 and 100 cells M -1.12 %,
#: D +0.97 %, midpoint -0.08 %; at V tau/a0 < 1e-4 and 192 cells M -1.1 %, D +2.8 %).
BLEND_ZETA = (1e-3, 5e-3)


def _blend_weight(zeta):
    lo, hi = math.log10(BLEND_ZETA[0]), math.log10(BLEND_ZETA[1])
    return jnp.clip((hi - jnp.log10(jnp.asarray(zeta, float))) / (hi - lo), 0.0, 1.0)


def full_model_value(moment, dissipation, zeta) -> jax.Array:
    """The reported R_r of a full model: the dissipation form, moved toward the midpoint of the
    two forms below :data:`BLEND_ZETA` (weight 1 at zeta <= 1e-3): ``D + w (M - D)/2``. Smooth
    in every input. Jittable."""
    return dissipation + 0.5 * _blend_weight(zeta) * (moment - dissipation)


#: Smallest ratio of the solved contact size to the size the cells are counted on
#: (:func:`counting_size`) for which the error tables hold: their calibration counted cells on
#: the relaxed size, and its solved contacts lay at 0.48..1 of it (the Prony series at 1e3 m/s:
#: 2.4 mm against 5.0 mm; SLS f = 3 at high speed: 0.63). Measured again with the counting size
#: (``benchmarks/dynamic_contact.py --calibration``, the study files of
#: ``benchmarks/resistance_forms.py``): 0.58..1, so the bound stands.
CALIBRATED_CONTACT_RATIO = 0.48

#: Lower bound on the ratio of the solved contact size to the dynamic estimate
#: (:func:`jaxroll.engines.contact_size.dynamic_contact_size`) used by :func:`counting_size`:
#: measured 0.82..1.02 over the tables' calibration and validation sets (the lowest: the
#: cylinder, SLS f = 3, at the loss peak zeta = 1, whose contact is shifted and asymmetric), and
#: 0.93..1.04 over the shipped measured material's map and SLS f = 3, 30 at zeta = 10..1000
#: (``benchmarks/dynamic_contact.py --quick``).
DYNAMIC_CONTACT_RATIO = 0.8
#: The same bound per geometry where the loss factor over the contact's frequencies exceeds
#: :data:`CALIBRATED_TAN_DELTA` (:func:`loss_beyond_calibration`: loss-dominated materials, SLS
#: f > ~11). Solved / dynamic size near the R_r peak (5 kN/m cylinder, 100 N sphere, R = 2 cm,
#: 30 mm layer and half-space, 3 mm/s-1 m/s; benchmarks/LOG.md 2026-11-29, "loss-dominated
#: contacts"): cylinder 0.68 (f = 30), 0.61 (f = 100), 0.55 (f = 1000); sphere 0.81, 0.78, 0.70.
#: With 0.8 the default cylinder at f = 1000 and 30 mm/s counted its cells on 3x its solved
#: half-width (4 cells on it) and stopped at max_steps_reached: the cylinder counts on 0.5. The
#: sphere keeps 0.8 (its contacts down to 0.70 of the dynamic size are covered by
#: :func:`full_model_error`'s contact shortfall, which reads the tables at the cells on the solved
#: contact); counted on a smaller size its finer grids at f = 100 fail to converge near the peak.
LOSS_DOMINATED_CONTACT_RATIO = {"sphere": 0.8, "cylinder": 0.5}


def counting_size(material, layer, radius, load, speed, geometry="sphere"):
    """The contact size [m] on which a full model's grid counts its cells (its window covers
    :data:`SPHERE_WINDOW_RADII` / :data:`LINE_WINDOW_RADII` of it) and its error bound reads the
    tables (:func:`full_model_error`): the relaxed estimate ``a_rel``
    (:func:`~jaxroll.engines.contact_size.estimate_contact_size`, the tables' calibration), or
    where the material is much stiffer at the rolling frequency than relaxed, the dynamic
    estimate ``a_dyn`` (:func:`~jaxroll.engines.contact_size.dynamic_contact_size`) scaled to the
    relaxed size of a calibration point with the same solved contact:
    ``min(a_rel, q a_dyn / rho)``, ``rho`` = :data:`CALIBRATED_CONTACT_RATIO` (the calibration
    holds down to solved/a_rel = rho) and ``q`` = :data:`DYNAMIC_CONTACT_RATIO` (the solved
    contact is at least ``q a_dyn``; :data:`LOSS_DOMINATED_CONTACT_RATIO` where
    :func:`loss_beyond_calibration` holds over ``V/a_rel .. 10 V/a_dyn``), so that the solved
    contact is at least ``rho`` times the counting size. Equal to ``a_rel`` wherever the dynamic
    estimate is above ``rho/q`` of it (e.g. a standard linear solid with ``f <= 3``). Jittable."""
    return _counting_and_window_sizes(material, layer, radius, load, speed, geometry)[0]


def loss_dominated_points(material, layer, radius, loads, speeds, geometry="sphere") -> np.ndarray:
    """Whether the loss factor over each point's contact frequencies, ``V/a_rel .. 10 V/a_dyn``
    (``a_rel``, ``a_dyn`` the relaxed and dynamic contact size estimates), exceeds
    :data:`CALIBRATED_TAN_DELTA` (:func:`loss_beyond_calibration`): there the full models' grids
    count cells on :data:`LOSS_DOMINATED_CONTACT_RATIO` of the dynamic size, and the sphere's
    automatic method switches on the contact search's continuation (``jr.Full(continuation=...)``).
    Points ``(loads[i], speeds[i])``, concrete; host NumPy booleans (the grid rules' program)."""
    loads = np.atleast_1d(np.asarray(loads, float)).ravel()
    speeds = np.broadcast_to(np.atleast_1d(np.asarray(speeds, float)).ravel(), loads.shape)
    return np.asarray(_compilation_cache.call(_counting_table, material, layer, as_float(radius), jnp.asarray(loads),
                                              jnp.asarray(speeds), geometry)[2])


def _counting_and_window_sizes(material, layer, radius, load, speed, geometry):
    """:func:`counting_size` and the size [m] the window covers :data:`SPHERE_WINDOW_RADII` /
    :data:`LINE_WINDOW_RADII` of: the counting size with ``q`` = :data:`DYNAMIC_CONTACT_RATIO`
    everywhere; and whether the point is loss-dominated (:func:`loss_dominated_points`). Where the
    material is loss-dominated the cells are counted on the smaller size
    (:data:`LOSS_DOMINATED_CONTACT_RATIO`) and the window keeps its width in metres: with both
    on the smaller size the default cylinder at f = 1000 (5 kN/m, 0.1-0.3 m/s) reached the
    window's edge."""
    a_rel = estimate_contact_size(material, layer, radius, load, geometry)
    a_dyn = dynamic_contact_size(material, layer, radius, load, speed, geometry)
    lossy = loss_beyond_calibration(material, speed, a_dyn, a_rel)
    q = jnp.where(lossy, LOSS_DOMINATED_CONTACT_RATIO[geometry], DYNAMIC_CONTACT_RATIO)
    return (jnp.minimum(a_rel, q * a_dyn / CALIBRATED_CONTACT_RATIO),
            jnp.minimum(a_rel, DYNAMIC_CONTACT_RATIO * a_dyn / CALIBRATED_CONTACT_RATIO), lossy)


#: Measured bias of the smoothed contact edge against the exact discrete contact on the default
#: grid, relative, largest over zeta = 0.01..100 and f = 0.3, 1, 3 (half-space;
#: benchmarks/edge_smoothing_bias.py): ``EDGE_BIAS_SCALE[g] * kappa^1.5`` is that envelope for
#: kappa = 0.125..1 (sphere: -0.73 / -2.06 % at kappa = 0.125 / 0.25, f = 3, zeta = 0.1, and
#: -3.85 / -8.65 % at kappa = 0.5 / 1, f = 1; cylinder -0.13 / -0.62 / -2.0 / -5.8 %, f = 1), and
#: ``EDGE_EXTRAPOLATED_BIAS[g]`` what is left after the Richardson extrapolation
#: (``Full(edge_extrapolation=True)``: sphere <= 0.135 %, cylinder <= 0.047 % measured).
EDGE_BIAS_SCALE = {"sphere3d": 0.17, "cylinder": 0.06}
EDGE_EXTRAPOLATED_BIAS = {"sphere3d": 1.4e-3, "cylinder": 5e-4}


def edge_smoothing_error(kappa, extrapolated, model) -> float:
    """Bound [relative] on the smoothed contact edge's bias (``Full(edge_smoothing=kappa)``, with
    ``extrapolated``: its Richardson extrapolation) for the full ``model`` (``"sphere3d"`` or
    ``"cylinder"``): :data:`ERROR_SAFETY` times the measured envelope (the extrapolated model
    adds it to its ``truncation``: :meth:`jaxroll.Full._result`)."""
    envelope = EDGE_EXTRAPOLATED_BIAS[model] if extrapolated else EDGE_BIAS_SCALE[model] * kappa**1.5
    return ERROR_SAFETY * envelope


#: Factor on the moment-dissipation gap per geometry where the loss factor exceeds the tables'
#: (:func:`loss_beyond_calibration`). The cylinder's gap is not a bracket there: the default
#: cylinder at f = 1000 (5 kN/m, R = 2 cm, 30 mm layer, 30 mm/s) lay 3.42 % above the grid with
#: twice its cells (whose own estimate is 0.42 %) against a gap of 2.93 %. The sphere's is: f =
#: 100 and 1000 at 10 mm/s, +1.31 % and +2.78 % from 32 cells per radius against gaps of 1.81 %
#: and 4.28 % (benchmarks/LOG.md 2026-11-29, "loss-dominated contacts").
LOSS_GAP_SAFETY = {"sphere": 1.0, "cylinder": 1.5}


def full_model_error(moment, dissipation, zeta, cells, geometry, contact_ratio=1.0, breadth=0.0,
                     thickness_ratio=0.0, loss_dominated=False) -> jax.Array:
    """The error estimate (``RollingResult.truncation``, relative) of a full model's reported
    value (:func:`full_model_value`; the dissipation form ``dissipation`` from zeta = 5e-3 up):
    :data:`ERROR_SAFETY` times :func:`dissipation_error` at the regime ``(zeta, breadth)``, the
    layer's ``thickness_ratio`` (counting size / H, 0 on a half-space) and the grid's ``cells``
    per estimated contact radius, and where the tables do not bound it at least the gap
    ``|moment - dissipation|/dissipation``: in the bracketing regime ``zeta <``
    :data:`BRACKETING_ZETA` (the moment form low, the dissipation form high; there the share of
    the gap left by the blend of :func:`full_model_value`), on grids coarser than the table's,
    where the solved contact is smaller than the counting size (:func:`counting_size`, on which
    ``cells`` are counted) by more than the calibration saw (``contact_ratio`` = solved/counting
    size below :data:`CALIBRATED_CONTACT_RATIO`, or :data:`THIN_CONTACT_RATIO` on layers past the
    thin-layer tables' first block: the estimate missed the contact; the table is then read at
    the cells scaled by the shortfall), and on layers thinner than the
    thin-layer tables' last block (:data:`THIN_RATIOS`), and where the material's loss factor
    over the contact's frequencies exceeds the tables' (``loss_dominated``,
    :func:`loss_beyond_calibration`). No gradient (an error estimate, not a model value)."""
    cols = SPHERE_ERROR_CELLS if geometry == "sphere" else LINE_ERROR_CELLS
    gap = jnp.abs(moment - dissipation) / jnp.maximum(jnp.abs(dissipation), 1e-300)
    floor = jnp.where(thickness_ratio > THIN_RATIOS[geometry][0], THIN_CONTACT_RATIO[geometry],
                      CALIBRATED_CONTACT_RATIO)
    shortfall = jnp.minimum(1.0, contact_ratio / floor)
    cells = cells * shortfall
    bracketing = zeta < BRACKETING_ZETA
    use_gap = (bracketing | (cells < cols[0]) | (shortfall < 1.0) | (thickness_ratio > THIN_RATIOS[geometry][-1])
               | loss_dominated)
    # with the truth between M and D, the value D + w (M - D)/2 is within (1 - w/2) of their gap;
    # a loss-dominated contact's gap is no bracket (LOSS_GAP_SAFETY)
    gap_share = (jnp.where(bracketing, 1.0 - 0.5 * _blend_weight(zeta), 1.0)
                 * jnp.where(loss_dominated, LOSS_GAP_SAFETY[geometry], 1.0))
    table = dissipation_error(zeta, cells, geometry, breadth, thickness_ratio)
    est = jnp.maximum(ERROR_SAFETY * table, jnp.where(use_gap, gap_share * gap, 0.0))
    return jax.lax.stop_gradient(est)



#: The cells per estimated contact size the full models' rule chooses from, and its cap:
#: :data:`SPHERE_ERROR_CELLS` up to :data:`MAX_SPHERE_RULE_CELLS`, :data:`LINE_ERROR_CELLS`.
RULE_CELLS = {"sphere": (SPHERE_ERROR_CELLS, MAX_SPHERE_RULE_CELLS),
              "cylinder": (LINE_ERROR_CELLS, LINE_ERROR_CELLS[-1])}


def _rule_cells_array(zeta, breadth, geometry, thickness_ratio=0.0) -> np.ndarray:
    """The fewest cells of :data:`RULE_CELLS` (at most its cap) whose envelope
    (:func:`dissipation_error`) at ``(zeta[i], breadth[i], thickness_ratio[i])`` meets
    :data:`TARGET_ERROR`, the cap where none does; host NumPy."""
    ladder, cap = RULE_CELLS[geometry]
    ladder = np.asarray(ladder)
    zeta = np.asarray(zeta, float)
    ratio = np.broadcast_to(np.asarray(thickness_ratio, float), zeta.shape)
    err = np.asarray(_compilation_cache.call(_dissipation_error_jit, zeta[:, None], ladder[None, :].astype(float),
                                             geometry, np.asarray(breadth, float)[:, None], ratio[:, None]))
    fit = (err <= TARGET_ERROR) & (ladder <= cap)[None, :]
    return np.where(fit.any(axis=1), ladder[np.argmax(fit, axis=1)], cap)


#: :func:`dissipation_error` as one compiled program for the host-side grid rule: eager, each of
#: its operations would compile a small program of its own in every new process (~50 of them,
#: the bulk of a first call's grid sizing when the model itself comes from the persistent cache)
_dissipation_error_jit = jax.jit(dissipation_error, static_argnames="geometry")


def sphere_cells_per_radius(zeta: float, breadth: float = 0.0, thickness_ratio: float = 0.0) -> int:
    """Cells per estimated contact radius of the full 3D model at regime ``(zeta, breadth)``
    (:func:`regime`) on a layer of ``thickness_ratio`` = radius / H (0: a half-space): the fewest
    of 12, 16, 20, 24, 32, 48 whose :func:`dissipation_error` is <= :data:`TARGET_ERROR` (0.5 %),
    48 where none is (zeta < 0.01). Standard linear solid on a half-space: 12 at zeta >= 0.32, 20
    at 0.1-0.32, 24 at 0.03-0.1, 32 at 0.01-0.03; a broad Prony spectrum near the peak: 16."""
    return _rule_cells_array([zeta], [breadth], "sphere", [thickness_ratio])[0].item()


def cylinder_cells_per_radius(zeta: float, breadth: float = 0.0, thickness_ratio: float = 0.0) -> int:
    """Cells per estimated half-width of the full 2D cylinder at regime ``(zeta, breadth)`` on a
    layer of ``thickness_ratio`` = half-width / H (0: a half-space): the fewest of 12, 25, 50, 100,
    200, 400 whose :func:`dissipation_error` is <= :data:`TARGET_ERROR` (0.5 %), 400 where none
    is."""
    return _rule_cells_array([zeta], [breadth], "cylinder", [thickness_ratio])[0].item()


@eqx.filter_jit
def _point_regime_table(material, speeds, sizes):
    return jax.vmap(lambda V, a: jnp.stack(regime(material, V, a)))(speeds, sizes)


def _regime_cells(material, layer, speeds, sizes, geometry) -> np.ndarray:
    """The cells per counting size the full model's rule asks for at each point ``(speeds[i],
    sizes[i])`` (concrete arrays of one length): by the regime (:func:`regime`; ``(1, 0)`` at rest)
    and the layer's thickness ratio ``sizes/H`` (:func:`_rule_cells_array`), and at least
    ``2 size/H`` on a finite layer (the compliance kernel is only ~H wide). Host NumPy."""
    speeds, sizes = np.asarray(speeds, float), np.asarray(sizes, float)
    zb = np.asarray(_compilation_cache.call(_point_regime_table, material, jnp.asarray(speeds), jnp.asarray(sizes)))
    zeta, breadth = np.where(speeds > 0, zb[:, 0], 1.0), np.where(speeds > 0, zb[:, 1], 0.0)
    H = float(np.asarray(layer.H))
    if not math.isfinite(H):
        return _rule_cells_array(zeta, breadth, geometry)
    cells = _rule_cells_array(zeta, breadth, geometry, sizes / H)
    return np.maximum(cells, [_cells(2.0 * r / H) for r in sizes])


#: Ratio of the ladder on which :meth:`AutoGrid.point_cells` rounds counting sizes below the
#: relaxed one down (points of a class then share a size, hence a bucket and its window).
SIZE_LADDER = 2.0 ** 0.125


def _quantised(sizes, relaxed):
    """``sizes`` [m] (each <= its ``relaxed`` size) rounded down to ``relaxed SIZE_LADDER^-k``
    (``k >= 0``): exact where equal to the relaxed size, else at most 9 % smaller (finer cells,
    a window 9 % narrower in contact sizes)."""
    k = np.floor(np.log(np.minimum(sizes / relaxed, 1.0)) / np.log(SIZE_LADDER) + 1e-9)
    return np.where(sizes < relaxed * (1 - 1e-12), relaxed * SIZE_LADDER ** np.minimum(k, -1.0), relaxed)


def _cells(x: float) -> int:
    """``ceil(x)`` for a cell count, blind to round-off: ``r / (r / 12)`` may come out as
    ``12 (1 + 1e-16)``, and a plain ceil would then add a cell (a new window size, hence a new
    compiled program) for a value that changed nothing but the last bit."""
    return int(math.ceil(round(x, 9)))


def _next_pow2(n):
    return 1 << max(1, int(math.ceil(math.log2(max(n, 2)))))


def _envelope(loads, speeds):
    loads = np.atleast_1d(np.asarray(loads, dtype=float)).ravel()
    speeds = np.atleast_1d(np.asarray(speeds, dtype=float)).ravel()
    if loads.size == 0 or speeds.size == 0:
        raise ValueError("resolve needs at least one load and one speed")
    if not (np.all(np.isfinite(loads)) and np.all(loads > 0)):
        raise ValueError(f"load P must be positive and finite; got {loads}")
    if not (np.all(np.isfinite(speeds)) and np.all(speeds >= 0)):
        raise ValueError(f"speed V must be >= 0 and finite; got {speeds}")
    return loads, speeds


@eqx.filter_jit
def _estimated_sizes(material, layer, radius, loads, geometry):
    # compiled once per (material type, shapes, geometry): eager, the root find's while loop would
    # be traced and compiled anew on every call
    return jax.vmap(lambda P: estimate_contact_size(material, layer, radius, P, geometry))(loads)


def _sizes(material, layer, radius, loads, geometry):
    """Estimated contact sizes [m] of every load (host NumPy)."""
    r = np.asarray(_compilation_cache.call(_estimated_sizes, material, layer, as_float(radius),
                                           jnp.asarray(loads), geometry))
    if not np.all(np.isfinite(r) & (r > 0)):
        raise ValueError(f"cannot size a grid: the estimated contact sizes are {r}")
    return r


@eqx.filter_jit
def _counting_table(material, layer, radius, loads, speeds, geometry):
    return jax.vmap(lambda P, V: _counting_and_window_sizes(material, layer, radius, P, V, geometry))(loads, speeds)


def _grid_sizes(material, layer, radius, loads, speeds, geometry):
    """``(counting, window)``: the sizes [m] the full models' grid rules count cells on at the
    points ``(loads[i], speeds[i])`` and those their windows cover (host NumPy):
    :func:`counting_size` and the window's size (:func:`_counting_and_window_sizes`), rounded
    down onto :data:`SIZE_LADDER` below the relaxed size (:func:`_quantised`), so that the
    points of a map share a few sizes."""
    loads = np.atleast_1d(np.asarray(loads, float)).ravel()
    speeds = np.broadcast_to(np.atleast_1d(np.asarray(speeds, float)).ravel(), loads.shape)
    r, w = (np.asarray(x) for x in _compilation_cache.call(_counting_table, material, layer, as_float(radius),
                                                         jnp.asarray(loads), jnp.asarray(speeds), geometry)[:2])
    if not np.all(np.isfinite(r) & (r > 0) & np.isfinite(w)):
        raise ValueError(f"cannot size a grid: the estimated contact sizes are {r}")
    relaxed = _sizes(material, layer, radius, loads, geometry)
    return _quantised(r, relaxed), _quantised(w, relaxed)


def _rule_sizes(material, layer, radius, loads, speeds, geometry, full):
    """``(sizes, window sizes, their speeds)`` an envelope's rule reads: for a full model the
    counting and window sizes (:func:`_grid_sizes`) of every load x speed pair, with the pairs'
    speeds; otherwise the relaxed size of every load (twice), and ``None``."""
    if not full:
        r = _sizes(material, layer, radius, loads, geometry)
        return r, r, None
    P, V = (x.ravel() for x in np.meshgrid(loads, speeds, indexing="ij"))
    return (*_grid_sizes(material, layer, radius, P, V, geometry), V)


def _longest_time(material) -> float:
    t = float(np.asarray(material.longest_time()))
    if not (math.isfinite(t) and t >= 0):
        raise ValueError(f"cannot size a grid: the material's longest retardation time is {t}")
    return t


def union(grids) -> FixedGrid:
    """The finest :class:`FixedGrid` that covers each of ``grids``: the smallest cell, a window
    as wide (in metres) as the widest, the longest period (``None`` if every grid is infinite),
    the largest Fourier cut-off. Used to resolve one method for sweeps over several materials,
    layers or radii."""
    grids = list(grids)
    if not grids:
        raise ValueError("union of no grids")
    periodic = [g.periodic for g in grids]
    if any(periodic) and not all(periodic):
        raise ValueError("cannot merge periodic and infinite-layer grids")
    dx = min(float(g.spacing) for g in grids)
    width = max(float(g.spacing) * g.window for g in grids)
    window = int(math.ceil(width / dx - 1e-9))
    if all(g.window % 2 for g in grids):
        window += 1 - window % 2  # keep an odd window odd (a cell centred under the sphere)
    elif not any(g.window % 2 for g in grids):
        window += window % 2
    period = None
    if all(periodic):
        period = (max(float(g.period[0]) for g in grids), max(float(g.period[1]) for g in grids))
    terms = [g.n_terms for g in grids if g.n_terms is not None]
    return FixedGrid(dx, window, period=period, n_terms=max(terms) if terms else None)
