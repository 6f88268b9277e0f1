r"""Indentation rolling resistance of a conveyor belt over idlers.

An idler roll is a rigid cylinder of diameter ``D`` rolling on the belt's bottom cover, a
viscoelastic layer bonded to the carcass (here: a rigid base; the cover is any layer-like object
the front doors take). In the frame of the belt the roll travels at the belt speed ``V``. Per unit
width of the roll's contact with the belt (plane strain) the cylinder methods of the library give
the resistance ``F_ir'`` [N/m] for the line load ``F_z'`` [N/m] (:func:`jaxroll.rolling_resistance`
with ``geometry="cylinder"``, by default the full 2D model). The conveyor quantities follow:

* per roll: ``F_ir = F_ir' l_c`` [N] with the contact length ``l_c`` [m] of the belt on the roll;
* the coefficient ``F_ir / F_z = F_ir' / F_z'`` [-] (the "indentation friction factor");
* per idler set: the sum over its rolls; power over a flight of ``n`` sets:
  ``P = n F_ir V`` [W] (:func:`flight_power`).

The load on each roll of a three-roll trough (:func:`trough_loads`) follows from the bulk
cross-section of ISO 5048 / DIN 22101 and a stated sharing rule (vertical columns). All SI:
m, N, N/m, kg/m, m/s, K, W.
"""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .engines.stack import cover_thickness, with_cover_thickness
from .io import write_table
from .maps import map_points
from .result import RESULTS, RollingResult
from .rolling import rolling_resistance, rolling_resistance_grid

__all__ = ["IndentationResult", "IdlerSetResult", "TroughLoads", "ConveyorMap", "indentation_resistance", "idler_set_resistance",
           "trough_loads", "belt_stack", "flight_power", "conveyor_map", "material_directions", "cover_thickness",
           "with_cover_thickness", "G_STANDARD"]

#: standard gravity [m/s^2]
G_STANDARD = 9.80665


class IndentationResult(eqx.Module):
    """Indentation rolling resistance of one idler roll (:func:`indentation_resistance`).

    Attributes:
        per_width: ``F_ir'`` [N/m], the resistance per unit contact width (the cylinder's R_r).
        per_idler: ``F_ir = F_ir' l_c`` [N] for the contact length ``l_c``.
        coefficient: ``F_ir' / F_z'`` [-].
        line_load: ``F_z'`` [N/m]; contact_length: ``l_c`` [m].
        rolling: the cylinder's :class:`jaxroll.RollingResult` (validity, contact half-width).
    """

    per_width: jax.Array
    per_idler: jax.Array
    coefficient: jax.Array
    line_load: jax.Array
    contact_length: jax.Array
    rolling: RollingResult

    @property
    def valid(self) -> jax.Array:
        return self.rolling.valid

    @property
    def result(self) -> jax.Array:
        return self.rolling.result


def indentation_resistance(material, layer=None, *, diameter, line_load, speed, contact_length=1.0, method=None,
                           throw=True) -> IndentationResult:
    """Indentation rolling resistance of a rigid idler roll on the belt's bottom cover.

    Args:
        material: the cover compound (any jaxroll material; ``jr.at_temperature(prony, wlf, T)``
            for a temperature); or a :class:`jaxroll.Stack` alone (cover and carcass plies,
            :func:`belt_stack`), which carries its materials.
        layer: the cover on a rigid carcass, a :class:`jaxroll.Layer` (``H`` the cover
            thickness [m]; ``nu``, ``rho``); ``None`` with a stack.
        diameter: idler diameter ``D`` [m] (radius ``D/2``).
        line_load: ``F_z'`` [N/m], the normal load per unit contact width.
        speed: belt speed ``V`` [m/s].
        contact_length: ``l_c`` [m], the belt's contact length on the roll (1: per metre).
        method, throw: as in :func:`jaxroll.rolling_resistance` (default: the full 2D model).

    Works under ``jax.jit``/``vmap``/``grad`` as the front door does (resolve the method first).
    """
    res = rolling_resistance(material, layer, radius=0.5 * jnp.asarray(diameter, float), load=line_load,
                             speed=speed, geometry="cylinder", method=method, throw=throw)
    q, lc = jnp.asarray(line_load, float), jnp.asarray(contact_length, float)
    return IndentationResult(res.value, res.value * lc, res.value / q, q, lc, res)


@dataclasses.dataclass(frozen=True)
class TroughLoads:
    """Normal loads on the rolls of one idler set (:func:`trough_loads`).

    Attributes:
        rolls: the roll names, ``("center", "wing")`` (or ``("flat",)``); count: rolls of each.
        normal_force: ``F_z`` [N] on one roll of each kind; contact_length: ``l_c`` [m].
        line_load: ``F_z' = F_z / l_c`` [N/m]; center_share: the bulk's share on the center roll.
        weight: the weight the set carries, ``(m_B + m_G) g s`` [N] (the reference of the set's
            coefficient); total_force: the sum of the rolls' normal forces [N] (above ``weight``
            in a trough: a wing's normal force is its column's weight over ``cos lambda``).
    """

    rolls: tuple
    count: tuple
    normal_force: np.ndarray
    contact_length: np.ndarray
    line_load: np.ndarray
    center_share: float
    weight: float

    @property
    def total_force(self) -> float:
        return float(np.dot(self.count, self.normal_force))


def _usable_width(B):
    """ISO 5048 / DIN 22101: the belt width the bulk covers, ``b = 0.9 B - 0.05`` (``B <= 2 m``),
    ``B - 0.25`` above [m]."""
    return 0.9 * B - 0.05 if B <= 2.0 else B - 0.25


def trough_loads(*, belt_width, belt_mass, bulk_mass, spacing, roll_length=None, trough_angle=0.0,
                 surcharge_angle=math.radians(20.0), g=G_STANDARD) -> TroughLoads:
    r"""Normal loads on the rolls of a flat or three-roll (equal rolls) idler set.

    Args:
        belt_width: belt width ``B`` [m].
        belt_mass: belt mass ``m_B`` per metre of conveyor [kg/m].
        bulk_mass: bulk mass ``m_G`` per metre of conveyor [kg/m].
        spacing: spacing ``s`` between idler sets [m] (each set carries ``s`` metres).
        roll_length: length ``l`` of each of the three rolls [m] (``None`` or
            ``trough_angle = 0``: a flat idler of one roll under the whole belt).
        trough_angle: trough angle ``lambda`` of the wing rolls [rad].
        surcharge_angle: surcharge angle ``theta`` of the bulk [rad].
        g: gravitational acceleration [m/s^2].

    Load sharing (stated assumption). The bulk cross-section is that of ISO 5048 / DIN 22101 for
    three equal rolls: over the usable width ``b`` (:func:`_usable_width`) a trapezoid of height
    ``h = (b - l)/2 sin lambda`` and a parabolic surcharge of top width
    ``w = l + (b - l) cos lambda`` and area ``w^2 tan(theta)/6``. Each roll carries the bulk in
    the vertical column above it (no shear between the columns) and the belt over it; a wing
    roll, frictionless, supports its column's weight ``W`` with the normal force
    ``W / cos lambda``. For ``B = 1.2 m``, ``l = 0.465 m``, ``lambda = 35 deg``,
    ``theta = 20 deg`` the center roll carries 67 % of the bulk. Contact lengths: ``l`` on the
    center roll, ``min(l, (B - l)/2)`` on a wing (the belt's edge).
    """
    B, s = float(belt_width), float(spacing)
    WB, WG = float(belt_mass) * g * s, float(bulk_mass) * g * s
    if min(B, s) <= 0 or min(belt_mass, bulk_mass) < 0 or belt_mass + bulk_mass <= 0:
        raise ValueError("belt_width and spacing must be positive, belt_mass and bulk_mass >= 0 [kg/m], not both 0")
    lam = float(trough_angle)
    if roll_length is None or lam == 0.0:
        return TroughLoads(("flat",), (1,), np.array([WB + WG]), np.array([B]), np.array([(WB + WG) / B]), 1.0,
                           WB + WG)
    l, th = float(roll_length), float(surcharge_angle)
    b = _usable_width(B)
    if not (0 < lam < math.pi / 2 and 0 <= th < math.pi / 2 and 0 < l < b):
        raise ValueError(f"a three-roll trough needs 0 < trough_angle < pi/2 (got {lam:g} rad), 0 <= surcharge_angle "
                         f"< pi/2 (got {th:g}) and 0 < roll_length < the bulk's width {b:g} m (got {l:g} m)")
    h = 0.5 * (b - l) * math.sin(lam)
    w = l + (b - l) * math.cos(lam)
    hs = 0.25 * w * math.tan(th)                          # apex of the parabola y = hs (1 - (2x/w)^2)
    area = (l + 0.5 * (b - l) * math.cos(lam)) * h + w * w * math.tan(th) / 6.0
    center = l * h + hs * (l - l**3 / (3.0 * w * w))      # the column above the center roll
    share = center / area
    lw = min(l, 0.5 * (B - l))
    F = np.array([share * WG + WB * l / B, (0.5 * (1 - share) * WG + WB * 0.5 * (B - l) / B) / math.cos(lam)])
    lc = np.array([l, lw])
    return TroughLoads(("center", "wing"), (1, 2), F, lc, F / lc, share, WB + WG)


@dataclasses.dataclass(frozen=True)
class IdlerSetResult:
    """Indentation resistance of one idler set (:func:`idler_set_resistance`).

    Attributes:
        loads: the :class:`TroughLoads`; per_width: ``F_ir'`` [N/m] of each roll kind;
        per_roll: ``F_ir`` [N] of one roll of each kind; force: ``F_ir`` of the set [N];
        coefficient: ``F_ir / W`` of the set [-] (``W`` the weight it carries); power: ``F_ir V`` [W] of the set;
        result: the :data:`jaxroll.RESULTS` code per roll kind; valid: all rolls valid.
    """

    loads: TroughLoads
    per_width: np.ndarray
    per_roll: np.ndarray
    force: float
    coefficient: float
    power: float
    result: np.ndarray

    @property
    def valid(self) -> bool:
        return bool(np.all(self.result == RESULTS.successful))


def idler_set_resistance(material, layer=None, *, diameter, loads: TroughLoads, speed,
                         method=None) -> IdlerSetResult:
    """Indentation resistance of an idler set: every roll kind of ``loads`` (:func:`trough_loads`)
    at its line load, by the cylinder method (one compiled table over the roll kinds' loads);
    ``speed`` [m/s], ``diameter`` [m]. A roll whose point is not valid makes the set not valid
    (its value is still summed: read ``result``). ``material``, ``layer``: as in
    :func:`indentation_resistance` (a :class:`jaxroll.Stack` alone for carcass plies)."""
    q = np.asarray(loads.line_load, float)
    order = np.argsort(q)
    res = rolling_resistance_grid(material, layer, radius=0.5 * float(diameter), loads=q[order],
                                  speeds=[float(speed)], geometry="cylinder", method=method)
    inverse = np.argsort(order)
    per_width = np.asarray(res.value)[0][inverse]
    codes = np.asarray(res.result)[0][inverse]
    per_roll = per_width * loads.contact_length
    force = float(np.dot(loads.count, per_roll))
    return IdlerSetResult(loads, per_width, per_roll, force, force / loads.weight, force * float(speed), codes)


def belt_stack(cover, H, carcass=(), base="rigid", *, nu=0.5, rho=0.0):
    """The belt under the idler as a bonded stack: the bottom cover (``cover`` material,
    thickness ``H`` [m], Poisson ratio ``nu``, density ``rho`` [kg/m^3]) in contact, then the
    ``carcass`` plies (:class:`jaxroll.Ply`, top first), on ``base`` (``"rigid"`` or a
    :class:`jaxroll.HalfSpace`): ``jr.Stack([jr.Ply(cover, H, nu, rho), *carcass], base)``."""
    from .engines.stack import Ply, Stack

    return Stack([Ply(cover, H, nu=nu, rho=rho), *carcass], base=base)


def flight_power(force_per_idler, n_idlers, speed):
    """Power [W] to overcome the indentation resistance of ``n_idlers`` idler sets (or rolls),
    each ``force_per_idler`` [N], at the belt speed ``speed`` [m/s]: ``P = n F_ir V``."""
    return n_idlers * force_per_idler * speed


def material_directions(material) -> dict:
    """The material tangents of the map's material derivatives: ``"lnG"`` scales every modulus
    of ``material`` by one factor ``(1 + s)`` and ``"lntau"`` every time, so ``dF/ds`` at
    ``s = 0`` is ``dF/dln G`` (a stiffer compound) and ``dF/dln tau`` (a slower one) [N/m].
    For a :class:`jaxroll.StandardLinearSolid` also ``"f"``: the partial derivative in ``f``."""
    from .materials.material import GeneralizedMaxwell, StandardLinearSolid

    zero = jax.tree_util.tree_map(jnp.zeros_like, material)
    if isinstance(material, StandardLinearSolid):
        return {"lnG": eqx.tree_at(lambda m: m.G0, zero, material.G0),
                "lntau": eqx.tree_at(lambda m: m.tau, zero, material.tau),
                "f": eqx.tree_at(lambda m: m.f, zero, jnp.ones_like(material.f))}
    if isinstance(material, GeneralizedMaxwell):
        return {"lnG": eqx.tree_at(lambda m: (m.G_inf, m.G), zero, (material.G_inf, material.G)),
                "lntau": eqx.tree_at(lambda m: m.tau, zero, material.tau)}
    raise ValueError(f"no default material directions for a {type(material).__name__}; give directions={{name: "
                     f"tangent}} with tangents shaped like the material")


@dataclasses.dataclass(frozen=True)
class ConveyorMap:
    """Indentation resistance over temperature x speed x line load (:func:`conveyor_map`).

    Attributes:
        temperatures [K], speeds [m/s], line_loads [N/m]: the axes; contact_length ``l_c`` [m].
        per_width: ``F_ir'`` [N/m], shape ``(n_T, n_V, n_load)``; per_idler: ``F_ir'`` l_c [N];
        coefficient: ``F_ir' / F_z'`` [-].
        valid, result: per point (:data:`jaxroll.RESULTS`); never average over invalid points.
        dF_dT [N/(m K)], dF_dH [N/m^2]: derivatives of ``F_ir'`` in the temperature and the cover
            thickness; dF_dmaterial: ``{name: dF_ir'/ds}`` [N/m] along each material direction
            (:func:`material_directions`: ``lnG``, ``lntau``).
        seconds: wall time per point of the compiled map (values and every derivative).
    """

    temperatures: np.ndarray
    speeds: np.ndarray
    line_loads: np.ndarray
    contact_length: float
    per_width: np.ndarray
    valid: np.ndarray
    result: np.ndarray
    dF_dT: np.ndarray
    dF_dH: np.ndarray
    dF_dmaterial: dict
    seconds: float

    @property
    def per_idler(self) -> np.ndarray:
        return self.per_width * self.contact_length

    @property
    def coefficient(self) -> np.ndarray:
        return self.per_width / self.line_loads

    def write_csv(self, path):
        """One row per point (line load fastest): temperature [K], speed [m/s], line_load [N/m],
        F_ir per width [N/m] and per idler [N], the coefficient, the derivatives, valid and the
        :data:`jaxroll.RESULTS` name."""
        T, V, q = (a.ravel() for a in np.meshgrid(self.temperatures, self.speeds, self.line_loads, indexing="ij"))
        cols = {"temperature": T, "speed": V, "line_load": q, "F_ir_per_width": self.per_width.ravel(),
                "F_ir_per_idler": self.per_idler.ravel(), "coefficient": self.coefficient.ravel(),
                "dF_dT": self.dF_dT.ravel(), "dF_dH": self.dF_dH.ravel()}
        units = ["K", "m/s", "N/m", "N/m", "N", "-", "N/(m K)", "N/m^2"]
        for name, d in self.dF_dmaterial.items():
            cols[f"dF_d{name}"] = d.ravel()
            units.append("N/m")
        cols["valid"] = self.valid.ravel().astype(int)
        cols["result"] = [RESULTS.names[int(c)] for c in self.result.ravel()]
        units += ["-", "-"]
        write_table(path, cols, units, formats={k: ".8g" for k in cols if k not in ("valid", "result")})


def conveyor_map(material, shift, layer, *, diameter, line_loads, temperatures, speeds, contact_length=1.0,
                 method=None, directions=None, measured_temperatures=None, measured_frequencies=None) -> ConveyorMap:
    """``F_ir'(T, V, F_z')`` of an idler on a cover of a temperature-shifted compound, with the
    design derivatives, every point in one compiled program
    (:func:`jaxroll.maps.map_points`: the engine of :func:`jaxroll.resistance_map`).

    Args:
        material: the compound at ``shift.T_ref`` (e.g. ``jr.load_material(path)``); shift: its
            WLF/Arrhenius law.
        layer: the cover (:class:`jaxroll.Layer`; its ``H`` [m] is the thickness differentiated),
            or a :class:`jaxroll.Stack` with the cover as its top ply and carcass plies below
            (:func:`belt_stack`; each point shifts the cover, and every ply or base of a
            temperature-shifted material, to its temperature: :func:`jaxroll.maps.models_at`).
        diameter [m]; line_loads [N/m], temperatures [K], speeds [m/s]: 1D axes.
        contact_length: ``l_c`` [m] for ``per_idler``.
        method: default the full 2D model (an :class:`~jaxroll.grids.AutoGrid` gets one grid for
            the whole map).
        directions: ``{name: material tangent}``; default :func:`material_directions`.
        measured_temperatures, measured_frequencies: as in :func:`jaxroll.resistance_map`: points
            outside are computed but ``RESULTS.outside_measured_range``.
    """
    T, V, q = (np.asarray(x, float).ravel() for x in (temperatures, speeds, line_loads))
    directions = material_directions(material) if directions is None else dict(directions)
    Tp, Vp, qp = (a.ravel() for a in np.meshgrid(T, V, q, indexing="ij"))
    out = map_points(material, shift, layer, radius=0.5 * float(diameter), loads=qp, temperatures=Tp, speeds=Vp,
                     geometry="cylinder", method=method, measured_temperatures=measured_temperatures,
                     measured_frequencies=measured_frequencies, directions=tuple(directions.values()),
                     where="conveyor_map")
    shape = (T.size, V.size, q.size)
    dm = {name: out.dR_ddirection[k].reshape(shape) for k, name in enumerate(directions)}
    return ConveyorMap(T, V, q, float(contact_length), out.value.reshape(shape), out.valid.reshape(shape),
                       out.result.reshape(shape), out.dR_dT.reshape(shape), out.dR_dH.reshape(shape), dm, out.seconds)
