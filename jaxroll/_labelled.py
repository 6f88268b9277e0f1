"""Labelled views of result tables for pandas and xarray (optional dependencies: ``pip install
"jaxroll[xarray]"``), with named dimensions, coordinates and units.

Axis order (one convention for every table of jaxroll): the dimensions that a result has come in
the order **temperature, speed, load** (``ResistanceMap``: ``(temperature, speed)``;
``rolling_resistance_grid``: ``(speed, load)``). Units are SI and stored as ``attrs["units"]``
of each variable and coordinate (xarray), or in ``DataFrame.attrs["units"]`` (pandas, one entry
per column and index level).
"""

from __future__ import annotations

import importlib

import numpy as np

#: Dimension order of every labelled table: a result's dimensions are a subsequence of this.
DIMENSIONS = ("temperature", "speed", "load")
#: Units of the coordinates [SI]; a load is in N (sphere) or N/m (cylinder), set per table.
COORD_UNITS = {"temperature": "K", "speed": "m/s"}


def _require(module: str):
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(f"{module} is an optional dependency of jaxroll: pip install {module} "
                          f"(or the extra: pip install \"jaxroll[xarray]\")") from None


def _checked(coords: dict, fields: dict):
    dims = tuple(coords)
    if dims != tuple(d for d in DIMENSIONS if d in dims):
        raise ValueError(f"dimensions {dims} are not in the order {DIMENSIONS}")
    shape = tuple(len(c[0]) for c in coords.values())
    for name, (values, _) in fields.items():
        if np.shape(values) != shape:
            raise ValueError(f"{name} has shape {np.shape(values)}; the axes {dims} give {shape}")
    return dims


def to_xarray(coords: dict, fields: dict, attrs: dict | None = None):
    """An ``xarray.Dataset``; ``coords``: ``{dim: (values, unit)}`` in :data:`DIMENSIONS` order,
    ``fields``: ``{name: (array over the dims, unit)}``."""
    xr = _require("xarray")
    dims = _checked(coords, fields)
    return xr.Dataset({name: (dims, np.asarray(v), {"units": u}) for name, (v, u) in fields.items()},
                      coords={d: (d, np.asarray(v, float), {"units": u}) for d, (v, u) in coords.items()},
                      attrs=dict(attrs or {}))


def to_pandas(coords: dict, fields: dict, attrs: dict | None = None):
    """A ``pandas.DataFrame`` in long form: one row per point, indexed by the dims (a MultiIndex
    in :data:`DIMENSIONS` order, the last varying fastest), one column per field."""
    pd = _require("pandas")
    dims = _checked(coords, fields)
    index = pd.MultiIndex.from_product([np.asarray(v, float) for v, _ in coords.values()], names=list(dims))
    df = pd.DataFrame({name: np.ravel(v) for name, (v, _) in fields.items()}, index=index)
    df.attrs.update(attrs or {})
    df.attrs["units"] = {**{d: u for d, (_, u) in coords.items()}, **{n: u for n, (_, u) in fields.items()}}
    return df
