"""The roller geometry, the one place that knows what "sphere" and "cylinder" mean.

A rigid **sphere** makes a point contact: loads in N, rolling resistance in N, a 2D pressure
grid on the surface. A rigid **cylinder** makes a line contact in plane strain: loads and
rolling resistance per unit length, N/m, on a 1D grid. Every entry point takes
``geometry="sphere"`` or ``"cylinder"`` (or a :class:`Geometry` member, which equals its name).
"""

from __future__ import annotations

import enum

__all__ = ["GEOMETRIES", "Geometry", "as_geometry", "check_geometry"]


class Geometry(str, enum.Enum):
    """The roller: ``Geometry.sphere`` (point contact) or ``Geometry.cylinder`` (line contact,
    per unit length). A member equals its name as a string."""

    sphere = "sphere"
    cylinder = "cylinder"

    @property
    def load_unit(self) -> str:
        """Unit of loads and of the rolling resistance: ``"N"`` (sphere) or ``"N/m"`` (cylinder)."""
        return "N" if self is Geometry.sphere else "N/m"

    @property
    def surface_dims(self) -> int:
        """Dimensions of the contact grid on the surface: 2 (sphere) or 1 (cylinder)."""
        return 2 if self is Geometry.sphere else 1


#: The geometry names, as the front doors accept them.
GEOMETRIES = tuple(g.value for g in Geometry)


def as_geometry(geometry) -> Geometry:
    """``geometry`` (a name or a :class:`Geometry`) as a :class:`Geometry`; ``ValueError`` in one
    line for anything else."""
    try:
        return Geometry(geometry)
    except (ValueError, TypeError):
        raise ValueError(f"unknown geometry {geometry!r}; choose from {GEOMETRIES}") from None


def check_geometry(geometry) -> None:
    """Raise ``ValueError`` unless ``geometry`` names a :class:`Geometry`."""
    as_geometry(geometry)
