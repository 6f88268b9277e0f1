"""Peer check against the ``ContactMechanics`` package (PyPI; optional: skipped when absent).

ContactMechanics (Pastewka group, Freiburg) solves the static elastic contact of a rigid body on
an FFT-based periodic elastic substrate; its finite-thickness substrate is an elastic layer
(Young's modulus, Poisson ratio ``nu < 0.5``) bonded to a rigid base, with the Green's function
of Carbone & Mangialardi (JMPS 2008, eq. A.30) and the uniaxial (oedometric) stiffness at
``q = 0``. Its discretisation differs from ours: nodal point forces with the Green's function
sampled on the DFT bins only (no load-patch transform, no aliasing sum) and a constrained
conjugate-gradient solver (Polonsky-Keer), against our piecewise-constant pressure cells with the
patch transform folded exactly onto the grid and a primal-dual active-set solver
(:mod:`jaxroll.contact`). Both are second-order accurate for this smooth problem, so their
differences are the discretisation error.

Checks, on the same grid (128^2 cells of ``a = r_Hertz/12`` centred on the sphere apex):

* the layer compliance ``T_1(q)/G`` (:func:`jaxroll.engines.layer.static_compliance`; ours from
  [ZG] eq. 35 with ``kappa = 3 - 4 nu``) against their Green's function on every DFT bin, ``q = 0``
  included;
* the static elastic contact of a rigid sphere (``V = 0`` of the full 3D model,
  :func:`jaxroll.engines.sphere3d.static_pressure`, relaxed modulus ``G0``) on layers from thick
  (``gamma = r/H = 0.46``) to intermediate (``gamma = 2.3``, where neither Hertz/Jaffar nor the
  thin-layer law applies): penetration, peak pressure, contact radius (cell-quantised set and
  second-moment radius).

Measured (ContactMechanics 1.8.3, SurfaceTopography 1.27.1, muGrid 1.6.1): Green's function
ratio 1 +- 7e-16; penetration within 1.4e-3, peak pressure within 1.9e-3, moment radius within
8.5e-4, contact sets equal or one boundary ring apart.

Install for this test: ``pip install ContactMechanics`` (pulls SurfaceTopography, muGrid, NuMPI;
binary wheels, no compiler needed).
"""

import functools
import warnings

import jax
import numpy as np
import pytest

with warnings.catch_warnings():
    # NuMPI warns (ImportWarning) when mpi4py is absent and falls back to its serial stub
    warnings.simplefilter("ignore")
    cm = pytest.importorskip("ContactMechanics")
    st_mod = pytest.importorskip("SurfaceTopography")

import jaxroll as jr  # noqa: E402
from jaxroll.engines import sphere3d as s3  # noqa: E402
from jaxroll.engines.layer import static_compliance  # noqa: E402

G0, R, P = 3e6, 0.02, 10.0
N, CPR = 128, 12
A_H = float(jr.reference.hertz_sphere(P, R, G0).contact_radius)  # 2.32 mm
A = A_H / CPR  # cell size
L = N * A  # period (10.7 r)
W = 2 * int(np.ceil(1.6 * CPR)) + 1  # window: contact radius grows on thin layers


def _substrate(H, nu):
    return cm.PeriodicFFTElasticHalfSpace((N, N), 2.0 * G0 * (1.0 + nu), physical_sizes=(L, L), thickness=H,
                                          poisson=nu)


@pytest.mark.parametrize("H,nu", [(5e-3, 0.499), (1e-3, 0.3), (0.2e-3, 0.45), (30e-3, 0.0)])
def test_layer_compliance_matches_greens_function(H, nu):
    # their Green's function [m/Pa] (rfft layout: x = axis 0 halved) vs our T_1(|q|)/G0, q = 0
    # (oedometric compliance) included; both closed forms in float64: rounding only
    gf = np.real(np.asarray(_substrate(H, nu).greens_function))
    qx = 2 * np.pi * np.abs(np.fft.fftfreq(N, d=A))[: gf.shape[0]]
    qy = 2 * np.pi * np.fft.fftfreq(N, d=A)
    q = np.sqrt(qx[:, None] ** 2 + qy[None, :] ** 2)
    ours = np.asarray(static_compliance(jr.Layer(H, nu=nu), q)) / G0
    np.testing.assert_allclose(ours, gf, rtol=1e-12, atol=0)


def _contactmechanics_sphere(H, nu):
    sub = _substrate(H, nu)
    topo = st_mod.make_sphere(R, (N, N), (L, L), kind="paraboloid")  # apex on the grid point (N/2, N/2)
    system = cm.make_system(substrate=sub, surface=topo)
    res = system.minimize_proxy(external_force=P, pentol=1e-12 * A_H, forcetol=1e-10, maxiter=10000)
    assert res.success, res.message
    force = np.asarray(res.jac)  # nodal forces [N]
    x = (np.arange(N) - N // 2) * A
    r2 = x[:, None] ** 2 + x[None, :] ** 2
    return dict(
        penetration=float(res.offset),  # rigid-body approach; their q = 0 mode: oedometric, as ours
        peak=float(force.max()) / (A * A),
        r_set=float(np.sqrt(np.count_nonzero(force > 0) * A * A / np.pi)),
        r_moment=float(np.sqrt(2.5 * np.sum(force * r2) / np.sum(force))),
        total=float(force.sum()),
    )


@functools.partial(jax.jit, static_argnames=("nu",))
def _ours(H, nu):
    return s3.static_pressure(jr.StandardLinearSolid(G0, 0.25, 1.0), jr.Layer(H, nu=nu), R, P,
                              jr.FixedGrid(A, W, period=N * A))


@pytest.mark.parametrize("H,nu", [(5e-3, 0.499), (2e-3, 0.45), (1e-3, 0.499), (1e-3, 0.3)])
def test_static_sphere_vs_contactmechanics(H, nu):
    theirs = _contactmechanics_sphere(H, nu)
    ours = _ours(H, nu)
    assert int(ours.result) == 0
    assert theirs["total"] == pytest.approx(P, rel=1e-10)
    rel = {
        "penetration": float(ours.penetration) / theirs["penetration"] - 1.0,
        "peak": float(ours.peak_pressure) / theirs["peak"] - 1.0,
        "r_moment": float(ours.moment_radius) / theirs["r_moment"] - 1.0,
    }
    d_set = float(ours.contact_radius) - theirs["r_set"]
    print(f"\nH = {H * 1e3:g} mm, nu = {nu}, gamma = {float(ours.moment_radius) / H:.2f}: "
          + ", ".join(f"{k} {v:+.2e}" for k, v in rel.items()) + f", r_set diff {d_set / A:+.2f} cells")
    # nodal point forces vs piecewise-constant cells: O(a^2) discretisation difference at 12
    # cells per radius (measured <= 1.9e-3; it grows as H approaches a few cells)
    assert abs(rel["penetration"]) < 5e-3
    assert abs(rel["peak"]) < 5e-3
    assert abs(rel["r_moment"]) < 2e-3
    # contact sets: equal or one boundary cell group apart (cell quantisation of the set radius)
    assert abs(d_set) < 0.25 * A
