"""Failures, first calls and memory limits: the one-line :class:`jaxroll.SolverError` of
``throw=True``, compiled programs free of host callbacks (so that JAX's persistent compilation
cache can keep them), the cache's switch and directory, and the memory budget read from the
process's real limits (address space, cgroup)."""

import json
import os
import re
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jr
from jaxroll import _compilation_cache, _xla_options, grids
from jaxroll.apps.cli.options import runtime_message

SLS = jr.StandardLinearSolid(3e6, 0.25, 1.0)
THIN = jr.Layer(0.005)  # at 150 N, R = 2 cm: gamma > 0.9, outside Jaffar's thick-layer model
R = 0.02
ROOT = Path(__file__).resolve().parents[1]


def _direct(load, **kw):
    return jr.rolling_resistance(SLS, THIN, radius=R, load=load, speed=0.01, method="direct", **kw)


# ------------------------------------------------------------------ one-line failures


def test_throw_raises_a_solver_error_with_the_code_in_one_line():
    code = jr.RESULTS.outside_pressure_model
    with pytest.warns(jr.ValidityWarning):
        assert int(_direct(150.0, throw=False).result) == code  # the code the result carries
    with pytest.raises(jr.SolverError) as exc:
        _direct(150.0)
    err = exc.value
    assert isinstance(err, RuntimeError)
    assert (err.code, err.name, err.reason) == (code, "outside_pressure_model", jr.RESULTS.message(code))
    text = str(err)
    assert "\n" not in text and text.startswith("rolling resistance not trustworthy [RESULTS.outside_pressure_model]")
    assert text.endswith(jr.RESULTS.message(code))
    # a table: the first failing point's code, and the count (at 0.3 mm/s, below the R_r peak, the
    # 20 N point is valid; near the peak the method's estimated error would flag it too)
    with pytest.raises(jr.SolverError, match=r"at 1 of 2 points") as exc:
        jr.rolling_resistance_grid(SLS, THIN, radius=R, loads=[20.0, 150.0], speeds=[3e-4], method="direct",
                                   throw=True)
    assert exc.value.code == code and (exc.value.count, exc.value.total) == (1, 2)


def test_under_jit_the_failure_carries_the_same_line():
    # a traced load: the check runs inside the program (a host callback) and surfaces as
    # JAX's runtime error, whose text holds the SolverError line
    code = jr.RESULTS.outside_pressure_model
    with pytest.raises(jax.errors.JaxRuntimeError) as exc:
        jax.block_until_ready(jax.jit(lambda P: _direct(P).value)(150.0))
    assert runtime_message(exc.value) == jr.SolverError.message(code)


def test_front_door_programs_hold_no_host_callbacks_for_concrete_inputs():
    def hlo(fn, *args):
        return jax.jit(fn).lower(*args).as_text()

    # concrete inputs: checked on the host, the program only computes (cacheable)
    assert "callback" not in hlo(lambda: _direct(20.0, throw=False).value)
    # a traced input: its rules are checked inside the program
    assert "callback" in hlo(lambda P: _direct(P, throw=False).value, 20.0)
    # the contact solver's program too (a coarse cylinder grid: 24 cells in the window)
    full, half = jr.Full(grid=jr.FixedGrid(2e-4, 24)), jr.Layer(jnp.inf)  # (built inside jit, H would be traced)
    cylinder = lambda P: jr.rolling_resistance(SLS, half, radius=R, load=P, speed=0.01,  # noqa: E731
                                               geometry="cylinder", method=full, throw=False).value
    assert "callback" not in hlo(lambda: cylinder(1e4))
    assert "callback" in hlo(cylinder, 1e4)
    # a layer with inertia: its rule on the speed (below the shear-wave speed) is checked on the
    # host too (the README's layer, rho = 1000 kg/m^3)
    inertial = jr.Layer(0.03, rho=1000.0)
    rolling = lambda: jr.rolling_resistance(SLS, inertial, radius=R, load=1e4, speed=0.01,  # noqa: E731
                                            geometry="cylinder", method=full, throw=False).value
    assert "callback" not in hlo(rolling)


def test_supersonic_rolling_is_rejected_on_the_host_with_the_speeds():
    c_s = (3e6 / 1000.0) ** 0.5  # sqrt(G0 / rho) of the relaxed material [m/s]
    with pytest.raises(ValueError, match=r"shear-wave speed sqrt\(G0/rho\) of the layer.*got V = 60 m/s against 54.77"):
        jr.rolling_resistance(SLS, jr.Layer(0.03, rho=1000.0), radius=R, load=20.0, speed=60.0, method="direct")
    stack = jr.Stack([jr.Ply(SLS, H=0.01), jr.Ply(SLS, H=0.01, rho=1000.0)])
    with pytest.raises(ValueError, match=r"of ply 2"):
        jr.rolling_resistance_grid(SLS, stack, radius=R, loads=[20.0], speeds=[0.01, 1.01 * c_s], method="direct")


def test_concrete_inputs_are_checked_on_the_host():
    # tree_at skips the constructor's checks; the front door checks the values again
    bad = eqx.tree_at(lambda m: m.G0, SLS, jnp.asarray(-3e6))
    with pytest.raises(ValueError, match=r"G0 must be a positive, finite shear modulus in Pa; got -3e\+06"):
        jr.rolling_resistance(bad, THIN, radius=R, load=20.0, speed=0.01, method="direct")
    flat = eqx.tree_at(lambda l: l.H, THIN, jnp.asarray(-1.0))
    with pytest.raises(ValueError, match="H must be a positive thickness"):
        jr.rolling_resistance(SLS, flat, radius=R, load=20.0, speed=0.01, method="direct")


@pytest.mark.parametrize("method", [None, "direct"])
def test_wrongly_shaped_parameters_are_refused_in_one_line_before_compiling(method):
    """A parameter of the wrong shape names itself (found by an independent probe: before, a
    5-line while_loop type error from the default method's grid resolution, or "axis -1 is out
    of bounds" for a Prony series of scalars). Batches go through jax.vmap."""
    layer, kw = jr.Layer(0.03), dict(radius=R, load=100.0, speed=0.03, method=method)
    cases = [
        (dict(material=jr.StandardLinearSolid(jnp.array([3e6, 4e6]), 0.25, 1.0)),
         r"material\.G0 \(StandardLinearSolid\) must be a scalar"),
        (dict(layer=jr.Layer(jnp.array([0.03, 0.02]))), r"layer\.H \(Layer\) must be a scalar"),
        (dict(material=jr.GeneralizedMaxwell(1e6, 2e6, 0.1)),
         r"material\.G \(GeneralizedMaxwell\) must be a 1D array; got shape \(\)"),
        (dict(material=jr.at_temperature(SLS, jr.WLF(8.86, 101.6, 300.0), jnp.array([290.0, 300.0]))),
         r"material\.T \(AtTemperature\) must be a scalar"),
        (dict(radius=jnp.array([0.02, 0.03])), r"^radius must be a scalar"),
    ]
    for change, match in cases:
        args = {"material": SLS, "layer": layer, **kw, **change}
        with pytest.raises(ValueError, match=match) as info:
            jr.rolling_resistance(args.pop("material"), args.pop("layer"), **args)
        assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match=r"material\.G0 \(StandardLinearSolid\) must be a scalar"):
        jr.rolling_resistance_grid(cases[0][0]["material"], layer, radius=R, loads=[100.0], speeds=[0.03],
                                   method=method)
    shift, axes = jr.WLF(8.86, 101.6, 300.0), dict(speeds=[1e-3, 1e-2], temperatures=[300.0, 310.0])
    with pytest.raises(ValueError, match=r"material\.G0 \(StandardLinearSolid\) must be a scalar"):
        jr.resistance_map(cases[0][0]["material"], shift, layer, radius=R, load=100.0, method=method, **axes)
    with pytest.raises(ValueError, match=r"^radius must be a scalar"):
        jr.resistance_map(SLS, shift, layer, radius=jnp.array([0.02, 0.03]), load=100.0, method=method, **axes)
    with pytest.raises(ValueError, match=r"temperatures and speeds must be non-empty 1D arrays .* \(\) and \(2,\)"):
        jr.resistance_map(SLS, shift, layer, radius=R, load=100.0, method=method, speeds=[1e-3, 1e-2],
                          temperatures=300.0)


def test_a_map_with_a_static_column_warns_nothing_and_is_zero_there():
    """Speed 0 in a map (a static point: no dissipation) ran into a NumPy divide-by-zero warning
    while the points were ordered by log(V a_T) (found by an independent probe; the suite turns
    warnings into errors). Oracle: nothing rolls, R_r = 0 exactly."""
    out = jr.resistance_map(SLS, jr.WLF(8.86, 101.6, 300.0), jr.Layer(0.03), radius=R, load=100.0,
                            speeds=[0.0, 1e-2], temperatures=[300.0, 310.0], method="direct")
    assert np.all(out.valid[:, 0]) and np.all(out.value[:, 0] == 0.0) and np.all(out.value[:, 1] > 0.0)


def test_temperature_rules_are_checked_on_the_host_and_traced_ones_inside():
    """The shift law's rules (T > 0; WLF defined: C2 + T - T_ref > 0) on concrete temperatures
    raise a one-line ValueError on the host, from the front doors and the map (whose programs
    then hold no checks), and a traced temperature raises inside the program."""
    wlf = jr.WLF(8.86, 101.6, 293.15)  # undefined below 293.15 - 101.6 = 191.55 K
    cold = jr.at_temperature(SLS, wlf, 150.0)
    with pytest.raises(ValueError, match=r"^WLF shift undefined: C2 \+ T - T_ref <= 0 .*; got T = 150 K$"):
        _direct_of(cold)
    with pytest.raises(ValueError, match=r"WLF shift undefined.*got T = 180 K"):
        jr.resistance_map(SLS.to_prony(), wlf, THIN, radius=R, load=20.0, temperatures=[293.15, 180.0],
                          speeds=[0.01], method="direct")
    with pytest.raises(ValueError, match=r"temperature must be positive, in kelvin; got T = -5 K"):
        jr.resistance_map(SLS.to_prony(), jr.Arrhenius(1e5, 293.15), THIN, radius=R, load=20.0,
                          temperatures=[-5.0], speeds=[0.01], method="direct")
    assert float(_direct_of(jr.at_temperature(SLS, wlf, 250.0)).value) > 0  # defined: no error
    # the laws' own parameters, at construction (a NaN would reach every shifted modulus)
    with pytest.raises(ValueError, match=r"WLF.C2 must be a positive, finite number of kelvin; got nan"):
        jr.WLF(8.86, float("nan"), 293.15)
    # C2 <= 0: the pole at or above T_ref (before, accepted, and then every temperature, T_ref's
    # own included, was refused as "too far below T_ref")
    with pytest.raises(ValueError, match=r"WLF.C2 must be a positive, finite number of kelvin; got -101.6"):
        jr.WLF(8.86, -101.6, 293.15)
    with pytest.raises(ValueError, match=r"Arrhenius.T_ref must be a positive, finite temperature in K; got 0"):
        jr.Arrhenius(1e5, 0.0)
    # a Stack's lower ply is checked on the host too (the front door's program holds no checks)
    stack = jr.Stack([jr.Ply(SLS, H=0.003), jr.Ply(cold, H=0.003)])
    with pytest.raises(ValueError, match=r"WLF shift undefined.*got T = 150 K"):
        jr.rolling_resistance(SLS, stack, radius=R, load=20.0, speed=0.01, method="direct", throw=False)
    # a joint fit: the initial law at the DMA temperatures on the host (a fitted C2 is checked inside)
    dma = jr.DMAData(np.array([1.0, 10.0]), np.array([3e6, 4e6]), np.array([1e5, 2e5]),
                     temperature=np.array([293.15, 250.0]))
    with pytest.raises(ValueError, match=r"WLF shift undefined.*got T = 250 K"):
        jr.fit_material(jr.RollingData(np.array([0.01]), np.array([20.0]), np.array([0.1])), dma,
                        initial=SLS, layer=THIN, radius=R, method="direct", shift=jr.WLF(8.86, 30.0, 293.15))
    with pytest.raises(jax.errors.JaxRuntimeError, match="WLF shift undefined"):
        jax.block_until_ready(jax.jit(lambda T: _direct_of(jr.at_temperature(SLS, wlf, T)).value)(150.0))


def test_shift_factor_beyond_its_range_is_refused():
    """A shift factor beyond 1e100 (WLF just above its pole: C2 + T - T_ref = 0.01 K gives
    log10 a_T = 17.4 * 51.59 / 0.01 ~ 9e4; Arrhenius at 5 K: E_a/(R ln 10) (1/5 - 1/300) ~ 1027
    decades for 100 kJ/mol) is refused in one line, naming the temperature: before, a_T overflowed
    to inf and the map or the front door failed on an infinite reduced speed or a NaN contact size.
    Within the range (Arrhenius at 60 K: 70 decades) the point is computed, and a traced
    temperature is checked inside the program."""
    wlf = jr.WLF(17.4, 51.6, 300.0)  # pole at 248.4 K
    with pytest.raises(ValueError, match=r"^WLF shift factor out of range: \|log10 a_T\| > 100 .*"
                                         r"got log10 a_T = 8.97\de\+04 at T = 248.41 K$"):
        jr.resistance_map(SLS.to_prony(), wlf, THIN, radius=R, load=20.0, temperatures=[300.0, 248.41],
                          speeds=[0.01], method="direct")
    arr = jr.Arrhenius(1e5, 300.0)
    expected = 1e5 / 8.314462618 * (1 / 5.0 - 1 / 300.0) / np.log(10.0)  # 1027 decades
    with pytest.raises(ValueError, match=rf"^Arrhenius shift factor out of range.*log10 a_T = {expected:.4g} at T = 5 K$"):
        _direct_of(jr.at_temperature(SLS, arr, 5.0))
    assert float(_direct_of(jr.at_temperature(SLS, arr, 60.0)).value) >= 0  # 70 decades: computed
    with pytest.raises(jax.errors.JaxRuntimeError, match="Arrhenius shift factor out of range"):
        jax.block_until_ready(jax.jit(lambda T: _direct_of(jr.at_temperature(SLS, arr, T)).value)(5.0))


def _direct_of(material):
    with warnings.catch_warnings():  # (the direct method's validity is not what is checked here)
        warnings.simplefilter("ignore", jr.ValidityWarning)
        return jr.rolling_resistance(material, THIN, radius=R, load=20.0, speed=0.01, method="direct", throw=False)


def test_map_programs_hold_no_host_callbacks_after_the_host_checks(monkeypatch):
    """The map checks its concrete inputs on the host (map_points), so its program on a
    :class:`jaxroll.Layer`, with inertia or without, holds no check (JAX's persistent cache can
    keep it: a second process's first map neither traces nor compiles it, benchmarks/README.md);
    on a :class:`jaxroll.Stack` (whose plies may carry shift laws of their own, evaluated at the
    map's temperatures) the rules are checked inside, and that program is not stored."""
    from jaxroll import buckets

    texts = []

    def lowered(fn, args, static, store):
        texts.append((fn.lower(*args, **static).as_text(), store))
        raise StopIteration  # nothing compiled or run

    monkeypatch.setattr(buckets, "compiled", lowered)
    wlf, cylinder, prony = jr.WLF(8.86, 101.6, 293.15), jr.Full(grid=jr.FixedGrid(2e-4, 24)), SLS.to_prony()
    inertial = jr.Layer(0.03, rho=1000.0)
    for layer, method in ((jr.Layer(jnp.inf), cylinder), (inertial, "direct"),
                          (jr.Stack([jr.Ply(prony, H=0.03)]), "direct")):
        with pytest.raises(StopIteration):
            jr.resistance_map(prony, wlf, layer, radius=R, load=1e4, temperatures=[293.15],
                              speeds=[0.01], geometry="cylinder", method=method)
    # stored (its lowered program: jaxroll._compilation_cache.compiled) only without callbacks
    assert [("callback" in text, store) for text, store in texts] == [(False, True), (False, True), (True, False)]
    # the rule the inertial layer's program no longer checks: on the host (c_s = 54.8 m/s)
    with pytest.raises(ValueError, match=r"shear-wave speed sqrt\(G0/rho\) of the layer.*got V = 60 m/s"):
        jr.resistance_map(prony, wlf, inertial, radius=R, load=1e4, temperatures=[293.15], speeds=[60.0],
                          geometry="cylinder", method="direct")


# ------------------------------------------------------------------ compilation cache


def test_cache_directory_follows_the_environment(tmp_path):
    home, tag = Path("~/.cache").expanduser(), _compilation_cache.processor_tag()
    assert tag == _compilation_cache.processor_tag() and "/" not in tag  # one subdirectory per processor type
    assert _compilation_cache.cache_directory({}) == home / "jaxroll" / "jax" / tag
    assert _compilation_cache.cache_directory({"XDG_CACHE_HOME": str(tmp_path)}) == tmp_path / "jaxroll" / "jax" / tag
    for off in ("0", "off", "False", "no"):
        assert _compilation_cache.cache_directory({"JAXROLL_COMPILATION_CACHE": off}) is None
    assert _compilation_cache.cache_directory({"JAXROLL_COMPILATION_CACHE": "1"}) == home / "jaxroll" / "jax" / tag
    assert _compilation_cache.cache_directory({"JAXROLL_COMPILATION_CACHE": str(tmp_path / "c")}) == tmp_path / "c" / tag


_PROBE = textwrap.dedent("""
    import json, sys
    import jax
    import jaxroll as jr
    events = []
    jax.monitoring.register_event_listener(lambda name, **kw: events.append(name))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)  # store even a tiny program
    mat = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    jax.block_until_ready(jax.jit(lambda w: jr.materials.storage_modulus(mat, w))(jax.numpy.linspace(1.0, 2.0, 7)))
    print(json.dumps({"dir": jax.config.jax_compilation_cache_dir, "cap": jax.config.jax_compilation_cache_max_size,
                      "hits": events.count("/jax/compilation_cache/cache_hits")}))
""")


def _probe(env):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_COMPILATION", "JAXROLL_"))} | env
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_switched_off_cache_writes_nothing_and_a_jax_setting_wins(tmp_path):
    got = _probe({"XDG_CACHE_HOME": str(tmp_path), "JAXROLL_COMPILATION_CACHE": "0"})
    assert got["dir"] is None and not (tmp_path / "jaxroll").exists()
    mine = tmp_path / "mine"
    got = _probe({"XDG_CACHE_HOME": str(tmp_path), "JAX_COMPILATION_CACHE_DIR": str(mine)})
    assert got["dir"] == str(mine) and not (tmp_path / "jaxroll").exists()


def test_second_process_loads_the_compiled_program_from_the_cache(tmp_path):
    cache = tmp_path / "cache"
    first = _probe({"JAXROLL_COMPILATION_CACHE": str(cache)})
    files = sorted(p.name for p in cache.rglob("*") if p.is_file())
    assert Path(first["dir"]).parent == cache and files
    assert first["cap"] == -1  # JAX's own size cap stays off (it cannot write into a folder filled without it)
    second = _probe({"JAXROLL_COMPILATION_CACHE": str(cache)})
    assert second["hits"] > first["hits"]  # (the first may hit too: one program compiled twice)
    assert sorted(p.name for p in cache.rglob("*") if p.is_file()) == files  # nothing compiled anew


_TRACES = []


@eqx.filter_jit
def _scaled(x, factor, label):
    _TRACES.append(label)  # once per trace
    return {"y": jnp.sin(x) * factor, "total": jnp.sum(jnp.exp(x)) / factor, "n": jnp.asarray(len(label))}


def _forget(fn):
    """Drop this process's loaded programs of ``fn`` (as a new process would start)."""
    for key in [k for k in _compilation_cache._memo if k[0] is fn]:
        del _compilation_cache._memo[key]


def _same_bits(a, b):
    la, lb = jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)
    return jax.tree_util.tree_structure(a) == jax.tree_util.tree_structure(b) and all(
        u.dtype == v.dtype and u.weak_type == v.weak_type and bool(jnp.all(u == v)) for u, v in zip(la, lb))


def test_lowered_program_is_stored_loaded_and_gives_the_same_bits(tmp_path, monkeypatch):
    """:func:`jaxroll._compilation_cache.call`: the first call stores the lowered program, a
    "new process" (its memory of loaded programs dropped) runs it without tracing, bit for bit
    what the function gives; a new static value is a new program; traced callers and the
    switched-off cache run the function itself."""
    monkeypatch.setattr(_compilation_cache, "programs_directory", lambda: tmp_path)
    call, x, f = _compilation_cache.call, jnp.linspace(0.1, 1.0, 5), jnp.asarray(3.0)
    _forget(_scaled)
    n = len(_TRACES)
    first = call(_scaled, x, f, "a")
    assert len(_TRACES) == n + 1 and len(list(tmp_path.glob("_scaled-*.pkl"))) == 1
    assert _same_bits(first, _scaled(x, f, "a"))
    _forget(_scaled)
    n = len(_TRACES)
    x2, f2 = x + 0.25, jnp.asarray(0.7)
    assert _same_bits(call(_scaled, x2, f2, "a"), _scaled(x2, f2, "a")) and len(_TRACES) == n  # loaded, not traced
    assert call(_scaled, x, f, "bb")["n"] == 2 and len(list(tmp_path.glob("_scaled-*.pkl"))) == 2  # static: new key
    assert call(_scaled, x[:3], f, "a")["y"].shape == (3,) and len(list(tmp_path.glob("_scaled-*.pkl"))) == 3
    # traced callers take the function itself (grad through it, nothing stored)
    g = jax.grad(lambda s: call(_scaled, x, s, "a")["total"])(f)
    assert float(g) == pytest.approx(-float(jnp.sum(jnp.exp(x))) / 9.0, rel=1e-14)  # d(S/f)/df = -S/f^2
    assert len(list(tmp_path.glob("*.pkl"))) == 3
    # a static value without an identifying text (a function) is not stored
    assert call(_scaled, x, f, (print,))["n"] == 1 and len(list(tmp_path.glob("*.pkl"))) == 3
    # the switch: nothing read or stored
    monkeypatch.undo()
    monkeypatch.setenv("JAXROLL_COMPILATION_CACHE", "0")
    assert _compilation_cache.programs_directory() is None
    _forget(_scaled)
    n = len(_TRACES)
    assert _same_bits(call(_scaled, x, f, "ccc"), _scaled(x, f, "ccc")) and len(_TRACES) == n + 1


@eqx.filter_jit
def _scaled_by_keyword(x, factor, *, label):
    _TRACES.append(label)  # once per trace
    return jnp.sin(x) * factor + len(label)


def test_a_program_compiled_ahead_with_static_keywords_is_stored_and_loaded(tmp_path, monkeypatch):
    """:func:`jaxroll.buckets.compiled` (the map's and the batched points' programs, compiled
    before they run) through :func:`jaxroll._compilation_cache.compiled`: the lowered program is
    stored with its static keyword arguments in its key, and a "new process" (both memories of
    compiled programs dropped) loads it without tracing, with the function's own bits; another
    keyword value is another program."""
    from jaxroll import buckets

    monkeypatch.setattr(_compilation_cache, "programs_directory", lambda: tmp_path)
    monkeypatch.setattr(buckets, "_PROGRAMS", {})
    x, f = jnp.linspace(0.1, 1.0, 6), jnp.asarray(2.0)
    run, seconds = buckets.compiled(_scaled_by_keyword, (x, f), {"label": "kw"}, store=True)
    assert len(list(tmp_path.glob("_scaled_by_keyword-*.pkl"))) == 1 and seconds > 0
    assert _same_bits(run(x + 1.0, f), _scaled_by_keyword(x + 1.0, f, label="kw"))
    n = len(_TRACES)
    monkeypatch.setattr(buckets, "_PROGRAMS", {})
    run, _ = buckets.compiled(_scaled_by_keyword, (x, f), {"label": "kw"}, store=True)
    assert _same_bits(run(x * 3.0, f / 2), _scaled_by_keyword(x * 3.0, f / 2, label="kw"))
    assert len(_TRACES) == n  # loaded, not traced (the direct call's program is jit's, traced above)
    other, _ = buckets.compiled(_scaled_by_keyword, (x, f), {"label": "other"}, store=True)
    assert float(other(x, f)[0]) == pytest.approx(float(jnp.sin(x[0]) * 2.0 + 5.0), rel=1e-15)  # len("other") = 5
    assert len(list(tmp_path.glob("_scaled_by_keyword-*.pkl"))) == 2
    # a NumPy scalar is an input of the stored program, as of the function's own (not a constant)
    monkeypatch.setattr(buckets, "_PROGRAMS", {})
    run, _ = buckets.compiled(_scaled_by_keyword, (x, np.float64(2.0)), {"label": "np"}, store=True)
    assert _same_bits(run(x, np.float64(5.0)), _scaled_by_keyword(x, np.float64(5.0), label="np"))


def test_a_program_compiled_ahead_is_the_one_the_call_runs(caplog, monkeypatch):
    """:func:`jaxroll._compilation_cache.compile_ahead` (the fit's next window): the program of
    ``call(fn, *args, store=False)`` traced and compiled in a background thread; the call waits
    for it and then compiles and traces nothing, with the function's own numbers (another static
    value or shape is another program, not started twice)."""
    from _cases import compilations

    monkeypatch.setattr(_compilation_cache, "compiler_options", lambda: {})  # as with jaxroll's options
    x, f = jnp.linspace(0.2, 1.1, 7), jnp.asarray(1.5)
    _forget(_scaled)
    n = len(_TRACES)
    assert _compilation_cache.compile_ahead(_scaled, x, f, "ahead")
    assert not _compilation_cache.compile_ahead(_scaled, x + 1.0, f, "ahead")  # the same program: one thread
    out = []
    assert compilations(caplog, lambda: out.append(_compilation_cache.call(_scaled, x, f, "ahead", store=False))) == 0
    assert len(_TRACES) == n + 1  # traced once, in the thread
    assert _same_bits(out[0], _scaled(x, f, "ahead"))
    assert not _compilation_cache._ahead  # the call took the thread


def test_lowered_programs_folder_keeps_the_recently_used_under_its_cap(tmp_path, monkeypatch):
    """Storing a program trims the folder to its cap, least recently used first; loading a file
    marks it used (its modification time), so it outlives older unused ones."""
    monkeypatch.setattr(_compilation_cache, "programs_directory", lambda: tmp_path)
    x = jnp.linspace(0.1, 1.0, 5)
    _forget(_scaled)
    names = {}
    for label in ("a", "bb", "ccc"):
        before = {p.name for p in tmp_path.glob("*.pkl")}
        _compilation_cache.call(_scaled, x, jnp.asarray(2.0), label)
        (names[label],) = {p.name for p in tmp_path.glob("*.pkl")} - before
        for path in tmp_path.glob("*.pkl"):  # a clear order, oldest first: a, bb, ccc
            os.utime(path, (path.stat().st_mtime - 10.0,) * 2)
    sizes = {p.name: p.stat().st_size for p in tmp_path.glob("*.pkl")}
    assert len(sizes) == 3
    _forget(_scaled)
    _compilation_cache.call(_scaled, x, jnp.asarray(2.0), "a")  # loaded: "a" is now the most recent
    # a cap that holds two files of this size: the fourth program removes the two oldest, bb and ccc
    monkeypatch.setattr(_compilation_cache, "MAX_LOWERED_BYTES", 2 * max(sizes.values()) + 1)
    _compilation_cache.call(_scaled, x, jnp.asarray(2.0), "dddd")
    left = {p.name for p in tmp_path.glob("*.pkl")}
    assert len(left) == 2 and names["a"] in left and not {names["bb"], names["ccc"]} & left


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
def test_front_door_through_the_stored_program_gives_the_same_bits(tmp_path, monkeypatch):
    # the point as jr.rolling_resistance runs it with the stored programs on (the suite runs with
    # them off: tests/conftest.py), stored and then loaded, against the jitted function itself
    from jaxroll import rolling
    from jaxroll._numerics import as_float

    monkeypatch.setattr(_compilation_cache, "programs_directory", lambda: tmp_path)
    _forget(rolling._point)
    stored = _direct(20.0, throw=False)
    assert list(tmp_path.glob("_point-*.pkl"))
    _forget(rolling._point)
    loaded = _direct(20.0, throw=False)
    method = jr.methods.as_method("direct").dynamic()
    inputs = (as_float(R), as_float(20.0), as_float(0.01))
    want = rolling._point(method, SLS, THIN, *inputs, "sphere", False)
    assert _same_bits(stored, want) and _same_bits(loaded, want)
    # with jaxroll's XLA options (off in the suite by its XLA_FLAGS): the stored program's bits
    # are those of the function compiled as a top-level program with them, and differ from the
    # suite's compilation by rounding only
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    options = _xla_options.compiler_options()
    _forget(rolling._point)
    optioned = _direct(20.0, throw=False)
    arrays, static = eqx.partition((SLS, THIN), eqx.is_array)  # as the front door's program takes them
    top = jax.jit(lambda d, *a: rolling._point(method, *eqx.combine(d, static), *a, "sphere", False),
                  compiler_options=options)
    assert options and _same_bits(optioned, top(arrays, *inputs))
    assert float(optioned.value) == pytest.approx(float(want.value), rel=1e-13)  # rounding (closed forms)


@jax.jit
def _sines(x):  # a program whose optimised HLO differs with XLA:CPU's fusion emitters on and off
    return jnp.sum(jnp.sin(x) ** 2 + jnp.exp(x))


def _hlo(compiled) -> str:
    """The optimised HLO's instructions without their metadata (source locations)."""
    lines = compiled.as_text().splitlines()
    return "\n".join(re.sub(r", metadata=\{[^}]*\}", "", ln) for ln in lines if ln.lstrip().startswith(("%", "ROOT")))


def test_xla_options_follow_the_platform_the_switch_and_xla_flags():
    opts = _xla_options.compiler_options
    assert opts("cpu", {}) == _xla_options.CPU_OPTIONS and opts("cpu", {}) is not _xla_options.CPU_OPTIONS
    assert opts("gpu", {}) is None and opts("tpu", {}) is None  # XLA:CPU's keys go to CPU programs only
    for off in ("0", "off", "False", "no"):
        assert opts("cpu", {"JAXROLL_XLA_OPTIONS": off}) is None
    # an option the process's XLA_FLAGS sets stays the process's (the suite's level 0)
    kept = {k: v for k, v in _xla_options.CPU_OPTIONS.items() if k != "xla_backend_optimization_level"}
    assert opts("cpu", {"XLA_FLAGS": "--xla_backend_optimization_level=0"}) == (kept or None)
    assert opts("cpu", {"XLA_FLAGS": " ".join(f"--{k}=1" for k in _xla_options.CPU_OPTIONS)}) is None


def test_xla_options_reach_the_program_and_switch_off(tmp_path, monkeypatch):
    """:func:`jaxroll._compilation_cache.call` compiles a program that cannot be stored as a
    top-level program with jaxroll's XLA options, and so every program with the cache off: the
    optimised HLO is that of the options (here fusion emitters on, against the suite's
    ``XLA_FLAGS`` that turn them off); switched off, the function runs itself."""
    monkeypatch.setattr(_compilation_cache, "programs_directory", lambda: tmp_path)
    monkeypatch.setattr(_compilation_cache, "_lowered", lambda *a: False)  # as if it could not be stored
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    monkeypatch.setattr(_xla_options, "CPU_OPTIONS", {"xla_cpu_use_fusion_emitters": True})
    x = jnp.linspace(0.1, 1.0, 64)
    _forget(_sines)
    assert float(_compilation_cache.call(_sines, x)) == pytest.approx(float(_sines(x)), rel=1e-14)  # rounding
    (run, _), = [v for k, v in _compilation_cache._memo.items() if k[0] is _sines]
    lowered = run.lower(x)
    text = _hlo(lowered.compile())
    assert text == _hlo(lowered.compile({"xla_cpu_use_fusion_emitters": True}))
    assert text != _hlo(lowered.compile({"xla_cpu_use_fusion_emitters": False}))
    # the compilation cache off: the same in-process program with the options
    monkeypatch.setattr(_compilation_cache, "programs_directory", lambda: None)
    _forget(_sines)
    assert float(_compilation_cache.call(_sines, x)) == pytest.approx(float(_sines(x)), rel=1e-14)
    (run, _), = [v for k, v in _compilation_cache._memo.items() if k[0] is _sines]
    assert _hlo(run.lower(x).compile()) == text
    monkeypatch.setattr(_compilation_cache, "programs_directory", lambda: tmp_path)
    monkeypatch.setenv("JAXROLL_XLA_OPTIONS", "0")
    _forget(_sines)
    assert float(_compilation_cache.call(_sines, x)) == float(_sines(x))
    assert [v for k, v in _compilation_cache._memo.items() if k[0] is _sines] == [False]


_LAPACK_PROBE = """
import sys
import jax, jax.numpy as jnp
import jaxroll
from jaxroll import _compilation_cache, _xla_options

hits = []
jax.monitoring.register_event_listener(lambda name, **kw: hits.append(name == "/jax/compilation_cache/cache_hits"))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)  # store even this tiny program

@jax.jit
def solve(a, b):  # a LAPACK kernel (triangular solve), as a user's function may hold
    return jax.scipy.linalg.solve_triangular(a, b, lower=True)

a = jnp.tril(jnp.arange(1.0, 17.0).reshape(4, 4)) + 4 * jnp.eye(4)
x = _compilation_cache.call(solve, a, jnp.arange(1.0, 5.0))
print(repr(float(jnp.max(jnp.abs(a @ x - jnp.arange(1.0, 5.0))))), len(list(_compilation_cache.programs_directory().glob("*.pkl"))),
      sum(hits), bool(_xla_options.compiler_options()))
"""


def test_second_process_runs_a_stored_program_with_a_lapack_kernel(tmp_path):
    """A new process that loads a stored program lowers nothing, so jaxlib's LAPACK kernels were
    never prepared there: running one crashed the process (a segmentation fault) until
    :func:`jaxroll._compilation_cache.call` prepares them. Two real processes, the second loading
    what the first stored; the solve's residual is at rounding (exact system, 4 x 4). The program
    is compiled with jaxroll's XLA options (the suite's XLA_FLAGS left out), which are part of
    JAX's cache key: the second process finds the first one's compiled program."""
    script = tmp_path / "probe.py"
    script.write_text(_LAPACK_PROBE)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_COMPILATION", "JAXROLL_", "XLA_FLAGS"))}
    env |= {"JAXROLL_COMPILATION_CACHE": str(tmp_path / "cache"),
            "PYTHONPATH": str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")}
    hits = []
    for _ in range(2):
        out = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr[-2000:]
        residual, stored, hit, options = out.stdout.split()[-4:]
        assert float(residual) < 1e-12 and stored == "1" and options == "True"
        hits.append(int(hit))
    assert hits[1] > hits[0]  # the second process loads the compiled program


def test_import_before_jax_quiets_xla_log_only_with_the_cache_on():
    """``import jaxroll`` before JAX sets TF_CPP_MIN_LOG_LEVEL=3 (XLA's false SIGILL lines on
    loading cached programs) when the cache is on and the variable unset; JAX itself sets 1.
    The import loads neither SciPy nor the fits, and every public name resolves."""
    code = ("import sys, os\nif sys.argv[1] == 'jax': import jax\nimport jaxroll\n"
            "assert 'scipy' not in sys.modules  # imported where used: a stored program needs none of it\n"
            "assert 'jaxroll.identify' not in sys.modules  # public names of the fits etc. load on first use\n"
            "assert all(getattr(jaxroll, n) is not None for n in jaxroll.__all__) and callable(jaxroll.sweep)\n"
            "print(os.environ['TF_CPP_MIN_LOG_LEVEL'])")
    base = {k: v for k, v in os.environ.items() if k not in ("TF_CPP_MIN_LOG_LEVEL", "JAXROLL_COMPILATION_CACHE")}
    base["PYTHONPATH"] = str(ROOT) + os.pathsep + base.get("PYTHONPATH", "")

    def level(first, **env):
        out = subprocess.run([sys.executable, "-c", code, first], env=base | env, capture_output=True, text=True,
                             timeout=300)
        assert out.returncode == 0, out.stderr
        return out.stdout.strip().splitlines()[-1]

    assert level("jaxroll") == "3"
    assert level("jax") == "1"  # JAX was first: its own default
    assert level("jaxroll", JAXROLL_COMPILATION_CACHE="0") == "1"
    assert level("jaxroll", TF_CPP_MIN_LOG_LEVEL="0") == "0"


def test_lapack_threads_follow_the_environment():
    """SciPy's OpenBLAS thread count that jaxroll sets (jaxroll._threads): one by default, a
    user's OPENBLAS_NUM_THREADS wins, JAXROLL_LAPACK_THREADS sets or leaves it, and a bad value
    is one line."""
    from jaxroll import _threads

    assert _threads.requested_threads({}) == 1
    assert _threads.requested_threads({"OPENBLAS_NUM_THREADS": "4"}) is None
    assert _threads.requested_threads({"JAXROLL_LAPACK_THREADS": "3", "OPENBLAS_NUM_THREADS": "4"}) == 3
    assert all(_threads.requested_threads({"JAXROLL_LAPACK_THREADS": off}) is None for off in ("0", "off", "default"))
    with pytest.raises(ValueError, match="^JAXROLL_LAPACK_THREADS must be a positive thread count"):
        _threads.requested_threads({"JAXROLL_LAPACK_THREADS": "two"})


@pytest.mark.parametrize("order", ["jaxroll first", "scipy first"])
def test_scipys_openblas_runs_one_thread_and_numpys_is_left_alone(order):
    """Two processes on 2 cores each running a fit with OpenBLAS's default threads took 605 s
    each instead of 17 s (spinning threads; jaxroll._threads). After ``import jaxroll`` SciPy's
    OpenBLAS (under JAX's LAPACK kernels) runs one thread, whether SciPy loads before jaxroll or
    after it (then through the import hook); NumPy's OpenBLAS keeps the count it has without
    jaxroll. Oracle: threadpoolctl's view of the loaded libraries, in a fresh interpreter."""
    first = "import jaxroll, scipy.linalg" if order == "jaxroll first" else "import scipy.linalg, jaxroll"
    code = ("import json, sys\nif sys.argv[1] == 'with':\n    " + first + "\nelse:\n    import scipy.linalg\n"
            "from threadpoolctl import threadpool_info\n"
            "print(json.dumps({'scipy.libs' in i['filepath'] or '/scipy/' in i['filepath']: i['num_threads'] "
            "for i in threadpool_info() if i['internal_api'] == 'openblas'}))")
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "JAXROLL_LAPACK_THREADS")}
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")

    def threads(arg):
        out = subprocess.run([sys.executable, "-c", code, arg], env=env, capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout.strip().splitlines()[-1])

    with_jaxroll, without = threads("with"), threads("without")
    if "true" not in with_jaxroll:
        pytest.skip("SciPy links a shared BLAS here (no OpenBLAS inside its folders): nothing to set")
    assert with_jaxroll["true"] == 1
    assert with_jaxroll.get("false") == without.get("false")  # NumPy's: as without jaxroll


# ------------------------------------------------------------------ memory budget

GiB = 2**30


@pytest.fixture
def limits(tmp_path, monkeypatch):
    """A fake /proc and /sys/fs/cgroup (16 GiB available, no limit) and no RLIMIT_AS; tests
    write the limits they need into ``limits.proc`` / ``limits.cgroup`` / ``limits.rlimit``."""
    import resource

    proc, cgroup = tmp_path / "proc", tmp_path / "cgroup"
    (proc / "self").mkdir(parents=True)
    cgroup.mkdir()
    (proc / "meminfo").write_text(f"MemTotal: {32 * GiB // 1024} kB\nMemAvailable: {16 * GiB // 1024} kB\n")
    (proc / "self" / "status").write_text(f"Name: python\nVmSize: {GiB // 1024} kB\n")
    (proc / "self" / "cgroup").write_text("4:memory:/box\n0::/box\n")
    monkeypatch.setattr(grids, "PROC", proc)
    monkeypatch.setattr(grids, "CGROUP", cgroup)
    monkeypatch.delenv("JAXROLL_MEMORY_BUDGET", raising=False)
    state = type("Limits", (), {"proc": proc, "cgroup": cgroup, "rlimit": resource.RLIM_INFINITY})()
    monkeypatch.setattr(resource, "getrlimit", lambda which: (state.rlimit, resource.RLIM_INFINITY))
    return state


def _write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_budget_is_half_the_available_memory_without_limits(limits):
    budget, source = grids.memory_limit()
    assert budget == 8 * GiB and "available memory" in source
    assert jr.grids.memory_budget() == budget


def test_budget_honours_the_cgroup_v2_limit(limits):
    _write(limits.cgroup / "box" / "memory.max", f"{6 * GiB}\n")
    _write(limits.cgroup / "box" / "memory.current", f"{GiB}\n")
    assert grids.memory_limit() == (int(2.5 * GiB), "half of the cgroup memory limit left (container), 5.0 GiB")
    _write(limits.cgroup / "box" / "memory.max", "max\n")  # no limit: back to the available memory
    assert grids.memory_limit()[0] == 8 * GiB


def test_budget_honours_the_cgroup_v1_limit(limits):
    _write(limits.cgroup / "memory" / "memory.limit_in_bytes", f"{4 * GiB}\n")
    _write(limits.cgroup / "memory" / "memory.usage_in_bytes", f"{GiB}\n")
    assert grids.memory_limit()[0] == int(1.5 * GiB)
    _write(limits.cgroup / "memory" / "memory.limit_in_bytes", "9223372036854771712\n")  # the kernel's "none"
    assert grids.memory_limit()[0] == 8 * GiB


def test_budget_honours_the_address_space_limit(limits):
    limits.rlimit = 3 * GiB  # VmSize is 1 GiB: 2 GiB left
    budget, source = grids.memory_limit()
    assert budget == GiB and "RLIMIT_AS" in source


def test_memory_error_is_one_line_with_estimate_budget_and_source(limits):
    _write(limits.cgroup / "box" / "memory.max", f"{6 * 10**9}\n")  # a 6 GB container
    _write(limits.cgroup / "box" / "memory.current", "0\n")
    big = jr.Full(grid=jr.FixedGrid(1e-4, 55, period=0.4))
    need = big.grid.memory_estimate(2)
    assert need > 3e9  # above half of the container's limit, below the available memory
    with pytest.raises(ValueError) as exc:
        big.check_memory("sphere")
    text = str(exc.value)
    assert "\n" not in text
    assert f"needs about {need / GiB:.1f} GiB" in text and f"budget of {3e9 / GiB:.1f} GiB" in text
    assert "cgroup memory limit" in text and "JAXROLL_MEMORY_BUDGET" in text


# ------------------------------------------------------- plausibility: likely unit slips


@pytest.mark.parametrize(("kw", "match"), [
    (dict(radius=20.0), "radius R = 20 m is above 5 m"),  # 20 mm typed as 20
    (dict(radius=5e-5), "radius R = 5e-05 m is below 0.0001 m"),
    (dict(layer=jr.Layer(5.0)), "layer thickness H = 5 m is above 1 m"),  # 5 mm typed as 5
    (dict(material=jr.StandardLinearSolid(3.0, 0.25, 1.0)), "relaxed shear modulus G0 = 3 Pa is below 10000 Pa"),
    (dict(speed=360.0), "speed V = 360 m/s is above 100 m/s"),  # km/h typed as m/s... x 3.6 x 100
])
@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # slipped inputs may leave the model's range
def test_likely_unit_slips_warn_once_on_the_host(kw, match):
    """A value the rules allow but far outside the physical range gives one
    PlausibilityWarning naming it (the computation goes on with the value as given)."""
    args = dict(material=SLS, layer=jr.Layer(0.03), radius=R, load=100.0, speed=0.01) | kw
    with pytest.warns(jr.PlausibilityWarning, match=match) as record:
        jr.rolling_resistance(args.pop("material"), args.pop("layer"), method="direct", throw=False, **args)
    assert len([w for w in record if w.category is jr.PlausibilityWarning]) == 1


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # extreme but plausible: validity not the point
def test_plausible_inputs_and_traced_inputs_do_not_warn():
    """The range limits themselves, a half-space (H = inf) and traced values (no host check inside
    a compiled program) give no warning (warnings are errors in this suite)."""
    for radius, H, V in [(5.0, 1.0, 100.0), (1e-4, jnp.inf, 0.0)]:
        jr.rolling_resistance(SLS, jr.Layer(H), radius=radius, load=100.0, speed=V, method="direct", throw=False)
    f = jax.jit(lambda Rr: jr.rolling_resistance(SLS, jr.Layer(0.03), radius=Rr, load=100.0, speed=0.01,
                                                 method="direct", throw=False).value)
    assert jnp.isfinite(f(20.0))

