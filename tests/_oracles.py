"""High-precision oracles shared by tests (mpmath): the 6x6 transfer matrices of [ZG] eq. 22
(incompressible, with inertia, beta_y typo fixed) and of the compressible quasi-static layer.
Independent of the library's closed forms: T = e1^T T12 T22^{-1} e1 with T(z) = expm(A H).
And the viscoelastic Winkler foundation under a rolling cylinder (:func:`winkler_sls`)."""

import mpmath as mp
import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq


def _t_of_propagator(E):
    """``e1^T T12 T22^{-1} e1`` of the 6x6 propagator ``E`` (rigid base at its bottom)."""
    T12 = mp.matrix(3, 3)
    T22 = mp.matrix(3, 3)
    for i in range(3):
        for j in range(3):
            T12[i, j] = E[i, 3 + j]
            T22[i, j] = E[3 + i, 3 + j]
    return complex((T12 * mp.inverse(T22))[0, 0])


def _t_from_expm(A, H, dps):
    with mp.workdps(dps):
        return _t_of_propagator(mp.expm(A * H))


def _dps_for(q, H):
    # expm(A H) has entries ~e^{qH}; T12 T22^{-1} loses ~0.87 qH digits.
    return int(40 + 0.87 * q * H)


def _A_incompressible(vx, vy, G, rho, V):
    """[ZG] eq. 22's 6x6 ``A`` (mp values), beta_y typo fixed; ``G`` the mode modulus."""
    bx = (4 * vx**2 + vy**2) * G - rho * V**2 * vx**2
    by = (vx**2 + 4 * vy**2) * G - rho * V**2 * vx**2
    bxy = 3 * vx * vy * G
    i = mp.mpc(0, 1)
    return mp.matrix(
        [
            [0, -i * vx, -i * vy, 0, 0, 0],
            [-i * vx, 0, 0, 0, 1 / G, 0],
            [-i * vy, 0, 0, 0, 0, 1 / G],
            [-rho * V**2 * vx**2, 0, 0, 0, -i * vx, -i * vy],
            [0, bx, bxy, -i * vx, 0, 0],
            [0, bxy, by, -i * vy, 0, 0],
        ]
    )


def transfer_expm_incompressible(qx, qy, H, G, rho, V):
    """[ZG] eqs. 21-25 with beta_y = (qx^2 + 4 qy^2) G - rho V^2 qx^2 (typo fixed).
    ``G`` is the mode modulus G_m (complex) used as is."""
    dps = _dps_for((qx * qx + qy * qy) ** 0.5, H)
    with mp.workdps(dps):
        vx, vy, H, rho, V = (mp.mpf(x) for x in (qx, qy, H, rho, V))
        G = mp.mpc(G.real, G.imag)
        return _t_from_expm(_A_incompressible(vx, vy, G, rho, V), H, dps)


def _A_compressible(kx, ky, G, nu):
    """Quasi-static compressible 6x6 ``A`` (mp values), same state as :func:`_A_incompressible`."""
    lam = 2 * G * nu / (1 - 2 * nu)
    i = mp.mpc(0, 1)
    m = lam + 2 * G
    # w' = (s - i lam (kx u + ky v))/m ; u' = t_x/G - i kx w ; v' = t_y/G - i ky w
    # s' = -i kx t_x - i ky t_y
    # t_x' = lam kx (kx u + ky v) - i kx lam w' + 2G kx^2 u + G ky^2 u + G kx ky v  (and sym.)
    wp = [0, -i * lam * kx / m, -i * lam * ky / m, 1 / m, 0, 0]
    A = mp.matrix(6, 6)
    for j in range(6):
        A[0, j] = wp[j]
    A[1, 0], A[1, 4] = -i * kx, 1 / G
    A[2, 0], A[2, 5] = -i * ky, 1 / G
    A[3, 4], A[3, 5] = -i * kx, -i * ky
    row4 = [0, lam * kx * kx + 2 * G * kx * kx + G * ky * ky, lam * kx * ky + G * kx * ky, 0, 0, 0]
    row5 = [0, lam * kx * ky + G * kx * ky, lam * ky * ky + 2 * G * ky * ky + G * kx * kx, 0, 0, 0]
    for j in range(6):
        row4[j] += -i * kx * lam * wp[j]
        row5[j] += -i * ky * lam * wp[j]
        A[4, j] = row4[j]
        A[5, j] = row5[j]
    return A


def transfer_expm_compressible(qx, qy, H, G, nu):
    """Quasi-static compressible layer bonded to a rigid base; state (w, u, v, s_zz, t_xz, t_yz)
    with z up from the base, derived from Navier's equations (Lame lambda, mu = G)."""
    dps = _dps_for((qx * qx + qy * qy) ** 0.5, H)
    with mp.workdps(dps):
        kx, ky, H, nu = (mp.mpf(x) for x in (qx, qy, H, nu))
        G = mp.mpc(G.real, G.imag)
        return _t_from_expm(_A_compressible(kx, ky, G, nu), H, dps)


def transfer_expm_stack(qx, qy, plies, V, base=None, base_depth=60.0):
    """Surface compliance of bonded plies (top first) on a rigid base, from the product of the
    plies' 50-digit-class ``expm(A_j H_j)`` (z up from the base, the state (w, u, v, s_zz, t_xz,
    t_yz) continuous across interfaces). ``plies``: ``(H, G_m, rho, nu)`` each (``nu = 0.5``:
    [ZG] eq. 22 with inertia; ``nu < 0.5``: quasi-static compressible). ``base``: ``(G_m, rho,
    nu)`` of a half-space, represented by a ply of ``q H = base_depth`` on a rigid base (its
    half-space value to ``~e^{-2 base_depth Re s}``)."""
    q = (qx * qx + qy * qy) ** 0.5
    layers = list(plies) + ([] if base is None else [(base_depth / q,) + tuple(base)])
    dps = int(40 + 0.87 * q * sum(h for h, *_ in layers))
    with mp.workdps(dps):
        vx, vy, Vm = mp.mpf(qx), mp.mpf(qy), mp.mpf(V)
        E = mp.eye(6)
        for H, G, rho, nu in layers:  # top first: E = E_top ... E_bottom
            Gm = mp.mpc(complex(G).real, complex(G).imag)
            if nu == 0.5:
                A = _A_incompressible(vx, vy, Gm, mp.mpf(rho), Vm)
            else:
                assert rho == 0.0
                A = _A_compressible(vx, vy, Gm, mp.mpf(nu))
            E = E * mp.expm(A * mp.mpf(H))
        return _t_of_propagator(E)


def winkler_sls(P, R, H, G0, tau, f, nu, V):
    r"""Rolling resistance per unit width [N/m] of a rigid cylinder (radius ``R``, line load
    ``P`` [N/m], speed ``V``) on a one-dimensional Winkler foundation of a standard linear solid,
    the classical model of the conveyor-belt indentation resistance (Jonkers 1980, "The
    indentation rolling resistance of belt conveyors", Fördern und Heben 30; May, Morris and
    Atack 1959, J. Appl. Phys. 30, 1713; Rudolphi and Reicks 2006, "Viscoelastic indentation
    and resistance to motion of conveyor belts using a generalized Maxwell model of the backing
    material"), written independently of the library (tests/test_conveyor.py,
    benchmarks/conveyor_winkler.py).

    A thin compressible layer on a rigid base tends to a bed of independent columns in uniaxial
    strain, stiffness ``k = M/H`` with ``M = 2 G (1 - nu)/(1 - 2 nu)``. Each column follows the
    SLS law ``p + (tau/(1+f)) dp/dt = k0 (u + tau du/dt)`` ([ZG] eq. 12 with ``k0 = M0/H``); in
    the frame of the roller, which moves toward +x, ``d/dt = -V d/dx``. In contact (-b < x < a)
    ``u = d - x^2/(2R)`` with ``d = a^2/(2R)`` (the column ahead is unloaded), so
    ``p - c1 p' = k0 (u - c u')``, ``c = V tau``, ``c1 = c/(1+f)``, solved in closed form from
    ``p(a) = 0``: ``p = pp(x) - pp(a) exp((x - a)/c1)`` with
    ``pp = k0 [d - x^2/(2R) + c x/R + c1 (c - x)/R - c1^2/R]``. The rear edge ``-b`` is the first
    zero of ``p`` behind the roller (the surface then recovers freely); ``a`` is found from the
    load ``int p dx = P``; ``R_r = (1/R) int p x dx``."""
    k0 = 2 * G0 * (1 - nu) / ((1 - 2 * nu) * H)
    c, c1 = V * tau, V * tau / (1 + f)

    def pressure(a):
        d = a * a / (2 * R)
        pp = lambda x: k0 * (d - x * x / (2 * R) + c * x / R + c1 * (c - x) / R - c1 * c1 / R)  # noqa: E731
        return lambda x: pp(x) - pp(a) * np.exp((x - a) / c1)

    def rear(a):
        p = pressure(a)
        xs = np.linspace(a, -3 * a - 10 * c, 20001)
        i = int(np.argmax(p(xs[1:]) < 0)) + 1
        return brentq(p, xs[i], xs[i - 1], xtol=1e-15 * a)

    def load(a):
        return quad(pressure(a), rear(a), a, epsabs=0, epsrel=1e-13, limit=200)[0]

    a0 = (3 * P * R / (2 * k0)) ** (1 / 3)  # the elastic (relaxed) half-width
    a = brentq(lambda a: load(a) - P, 0.2 * a0, 5 * a0, xtol=1e-15 * a0)
    p = pressure(a)
    return quad(lambda x: p(x) * x, rear(a), a, epsabs=0, epsrel=1e-13, limit=200)[0] / R
