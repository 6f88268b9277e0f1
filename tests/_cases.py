"""Cases shared by the test modules: the paper's material and roller, standard layers, coarse
grids and methods, and a central finite-difference helper.

The suite is bound by compilation: the front doors compile once per static setup (method object,
geometry and input shapes; see jaxroll/rolling.py), and a ``jax.jit`` built inside a test case
compiles again at every case. Tests that build their cases from the objects here, with the same
shapes, share compiled programs within a module and, through the session's persistent
compilation cache (tests/conftest.py), across modules. Every object is immutable (equinox
modules), so sharing them cannot couple tests.
"""

import logging

import jax
import jax.numpy as jnp

import jaxroll as jr

#: The paper's standard linear solid: G0 = 3 MPa, tau = 0.25 s, f = 1 ([ZG] eq. 12, sec. 5).
PAPER = jr.StandardLinearSolid(3e6, 0.25, 1.0)
#: The paper's roller radius [m].
RADIUS = 0.02

#: Layers of the paper's cases: 30 mm (thick), 5 mm (thin), and a half-space.
THICK, THIN, HALF_SPACE = jr.Layer(0.03), jr.Layer(0.005), jr.Layer(jnp.inf)

#: Coarse 3D grid of the fit-grade model: 0.5 mm cells (r_c/8..r_c/11 at 80..150 N on the thick
#: layer), 29-cell window, 0.1 m period, 200 Fourier terms.
SPHERE_COARSE = jr.FixedGrid(5e-4, 29, period=0.1, n_terms=200)
#: A 16-cell line window of 1 mm cells (~5 per contact radius at 100 N): for plumbing and error
#: paths, where the checks and not the resolution are under test.
LINE_WINDOW16 = jr.FixedGrid(1e-3, 16, period=0.1)
#: SP slices on :data:`LINE_WINDOW16`.
SLICES_COARSE = jr.Slices("SP", grid=LINE_WINDOW16)


def central_difference(fun, params: dict, name: str, rel_step: float = 1e-5) -> float:
    """Central finite difference of the scalar ``fun(params)`` in ``params[name]``, step
    ``rel_step * |params[name]|``: truncation O(step^2), rounding ~eps * |fun| / step."""
    h = rel_step * abs(float(params[name]))
    up, down = dict(params), dict(params)
    up[name] = params[name] + h
    down[name] = params[name] - h
    return (float(fun(up)) - float(fun(down))) / (2 * h)


from _xla import XLA_LIGHT, default_xla_flags, light_xla_flags  # noqa: E402, F401  (re-exported for the tests)


def compilations(caplog, fn) -> int:
    """The number of XLA compilations while ``fn()`` runs (``jax.log_compiles``; ``caplog`` is
    pytest's fixture)."""
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="jax._src.dispatch"), jax.log_compiles(True):
        fn()
    return sum("Finished XLA compilation" in r.getMessage() for r in caplog.records)


def draw_loss_dominated(rng):
    """One random loss-dominated table: ``(material, layer, radius, loads, speeds, label)``, SLS
    f = 30..1000 (tan delta up to 15.8), G0 1..10 MPa, tau 0.01..1 s, R = 2 cm, 2 loads of
    10..150 N (sorted), 11 speeds 1e-4..10 m/s (sorted), a half-space (a quarter of the draws) or
    a layer of 0.3..100 relaxed contact radii at the larger load. The cases of
    ``tests/test_approximation.py``'s loss-dominated envelope and of
    ``benchmarks/loss_dominated.py approx`` (the same sequence for the same seed)."""
    import numpy as np

    speeds = np.sort(10 ** rng.uniform(-4, 1, 11))
    G0, tau, f = 10 ** rng.uniform(6, 7), 10 ** rng.uniform(-2, 0), 10 ** rng.uniform(np.log10(30), 3)
    mat, R = jr.StandardLinearSolid(G0, tau, f), 0.02
    loads = np.sort(10 ** rng.uniform(1, np.log10(150), 2))
    r = float(jr.engines.contact_size.estimate_contact_size(mat, HALF_SPACE, R, loads[-1]))
    H = np.inf if rng.uniform() < 0.25 else r * 10 ** rng.uniform(np.log10(0.3), 2)
    return mat, jr.Layer(H), R, loads, speeds, f"SLS G0={G0:.3g} tau={tau:.3g} f={f:.3g}"
