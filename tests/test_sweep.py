"""Tests of jaxroll.sweep: chunked, sharded sweeps over grids and point lists.

The sharded checks run in ONE child process with 8 forced host devices
(``XLA_FLAGS=--xla_force_host_platform_device_count=8`` must be set before jax is imported, so
it cannot be done in the pytest process). The child writes its results to an .npz file; the
oracles are computed here, in the parent, with numpy / scipy closed forms (an independent
implementation), and the child itself compares each sharded sweep with the single-device path
(``devices=1``) and with a plain ``jax.vmap``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jr

REPO = Path(jr.__file__).resolve().parents[1]

# ------------------------------------------------------------------------------------------
# numpy oracles (independent of jax)
# ------------------------------------------------------------------------------------------


def np_modulus(G0, tau, f, omega):
    """[ZG] eq. 12 in numpy."""
    return G0 * (1 + 1j * omega * tau) / (1 + 1j * omega * tau / (1 + f))


def np_solve_fn(a, b):
    """The child's batched-solve test function, in numpy: x = A^{-1} r, returns x.sum()."""
    A = np.array([[4.0 + a, b, 0.5], [b, 5.0, a], [0.5, a * b, 6.0 + b]])
    r = np.array([1.0, a, b])
    return np.linalg.solve(A, r).sum()


def np_loss(theta, omegas):
    """Child's gradient loss: sum_w G''(w)/G0 + sum_w [G'(w)/G0]^2 with shared theta=(G0,tau,f)."""
    G0, tau, f = theta
    g = np_modulus(G0, tau, f, omegas)
    return np.sum(g.imag / 3e6) + np.sum((g.real / 3e6) ** 2)


# ------------------------------------------------------------------------------------------
# the 8-device child
# ------------------------------------------------------------------------------------------

CHILD = textwrap.dedent(
    r'''
    import os, sys, json
    os.environ["XLA_FLAGS"] = "--xla_force_host_platform_device_count=8"
    os.environ["JAX_PLATFORMS"] = "cpu"
    import jax, jax.numpy as jnp, numpy as np, equinox as eqx
    import jaxroll as jr
    jax.config.update("jax_numpy_dtype_promotion", "strict")
    assert jax.device_count() == 8, jax.devices()
    out, meta = {}, {}

    def modulus(G0, tau, f, w):  # through jaxroll's material model, [ZG] eq. 12
        return jr.complex_modulus(jr.StandardLinearSolid(G0, tau, f), w)

    def same(a, b):
        return all(np.array_equal(np.asarray(x), np.asarray(y))
                   for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b)))

    def maxrel(a, b):
        """max |a - b| / max |b| per leaf (norm-relative: some gradient entries cross zero)."""
        return max(float(np.max(np.abs(np.asarray(x) - np.asarray(y))) / np.max(np.abs(np.asarray(y))))
                   for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b)))

    # 1. grid of SLS moduli: 3 x 2 x 7 = 42 points (42/8 uneven), vector + dict outputs
    def modulus_fn(p):
        g = modulus(p.G0, p.tau, 1.0, p.omega)
        return {"Gp": jnp.real(g), "Gpp": jnp.imag(g),
                "vec": jnp.stack([jnp.real(g), jnp.imag(g), p.omega])}
    grid = jr.Grid(G0=np.array([1e6, 3e6, 5e6]), tau=np.array([0.1, 0.25]),
                   omega=np.logspace(-2.0, 3.0, 7))
    sharded = jr.sweep(modulus_fn, grid, chunk_size=4)
    single = jr.sweep(modulus_fn, grid, chunk_size=4, devices=1)
    flat = jax.vmap(modulus_fn)(grid.points())
    meta["grid_shapes"] = {k: list(v.shape) for k, v in sharded.items()}
    meta["grid_same_single"] = same(sharded, single)
    meta["grid_vs_vmap_rel"] = maxrel(jax.tree.map(lambda y: y.reshape((-1,) + y.shape[3:]), sharded), flat)
    meta["grid_devices"] = len(sharded["Gp"].sharding.device_set)
    for k, v in sharded.items():
        out["grid_" + k] = np.asarray(v)

    # 2. point lists of awkward sizes with chunk sizes that divide nothing; a batched solve
    #    (jnp.linalg.solve under vmap: raises ShardingTypeError on Explicit mesh axes)
    def solve_fn(p):
        a, b = p["a"], p["b"]
        A = jnp.array([[4.0 + a, b, 0.5], [b, 5.0, a], [0.5, a * b, 6.0 + b]])
        r = jnp.stack([jnp.ones_like(a), a, b])
        return jnp.linalg.solve(A, r[:, None])[:, 0].sum()
    meta["uneven"] = []
    for n, cs in [(13, 3), (3, 5), (37, 2), (8, 8), (100, 7)]:
        pts = {"a": np.linspace(0.1, 2.0, n), "b": np.linspace(-1.0, 1.0, n) ** 2}
        s8 = jr.sweep(solve_fn, pts, chunk_size=cs)
        s1 = jr.sweep(solve_fn, pts, chunk_size=cs, devices=1)
        s3 = jr.sweep(solve_fn, pts, chunk_size=cs, devices=3) if n in (13, 100) else s1
        meta["uneven"].append({"n": n, "chunk": cs, "shape": list(s8.shape),
                               "same_single": same(s8, s1), "same_3": same(s8, s3)})
        if n == 13:  # an explicit device list not starting at device 0
            s5 = jr.sweep(solve_fn, pts, chunk_size=cs, devices=jax.devices()[3:8])
            meta["devices_list_same"] = same(s8, s5)
            meta["devices_list_ids"] = sorted(d.id for d in s5.sharding.device_set)
        out[f"solve_{n}_{cs}"] = np.asarray(s8)

    # 3. gradient through a sharded sweep w.r.t. shared parameters (closure) and grid axes
    omegas = np.logspace(-2.0, 3.0, 29)
    def loss(theta, om, devices=None, sharded=True, checkpoint=True):
        def fn(w):
            g = modulus(theta[0], theta[1], theta[2], w)
            return jnp.imag(g) / 3e6 + (jnp.real(g) / 3e6) ** 2
        vals = (jr.sweep(fn, om, chunk_size=2, devices=devices, checkpoint=checkpoint) if sharded
                else jax.vmap(fn)(om))
        return jnp.sum(vals)
    theta = jnp.array([3e6, 0.25, 1.0])
    g8 = jax.grad(loss)(theta, omegas)
    g1 = jax.grad(loss)(theta, omegas, devices=1)
    gv = jax.grad(loss)(theta, omegas, sharded=False)
    gj = jax.jit(jax.grad(loss))(theta, omegas)
    gn = jax.grad(loss)(theta, omegas, checkpoint=False)
    gom = jax.grad(loss, argnums=1)(theta, jnp.asarray(omegas))
    gomv = jax.grad(loss, argnums=1)(theta, jnp.asarray(omegas), sharded=False)
    out["grad_theta"], out["grad_omega"] = np.asarray(g8), np.asarray(gom)
    out["loss"] = np.asarray(loss(theta, omegas))
    meta["grad_vs_single_rel"] = maxrel(g8, g1)
    meta["grad_vs_vmap_rel"] = maxrel(g8, gv)
    meta["grad_jit_vs_eager_rel"] = maxrel(gj, g8)
    meta["grad_no_checkpoint_rel"] = maxrel(gn, g8)
    meta["grad_omega_vs_vmap_rel"] = maxrel(gom, gomv)

    # grad w.r.t. a Grid axis (replicated over devices: cotangents summed over devices)
    def grid_loss(G0s):
        gr = jr.Grid(G0=G0s, omega=jnp.asarray(omegas))
        fn = lambda p: jnp.imag(modulus(p.G0, 0.25, 1.0, p.omega)) / 3e6
        return jnp.sum(jr.sweep(fn, gr, chunk_size=3))
    out["grad_G0_axis"] = np.asarray(jax.grad(grid_loss)(jnp.array([1e6, 2e6, 4e6])))

    # 4. progress: callable and stderr line, under jit too
    calls = []
    jr.sweep(solve_fn, {"a": np.linspace(0.1, 2.0, 50), "b": np.ones(50)}, chunk_size=2,
             progress=lambda done, total: calls.append((int(done), int(total))))
    jax.effects_barrier()
    meta["progress_calls"] = calls
    jr.sweep(solve_fn, {"a": np.linspace(0.1, 2.0, 50), "b": np.ones(50)}, chunk_size=4, progress=True)
    jax.effects_barrier()
    jitted = jax.jit(lambda a: jr.sweep(solve_fn, {"a": a, "b": a}, chunk_size=2))
    meta["jit_same"] = same(jitted(np.linspace(0.1, 2.0, 19)),
                            jr.sweep(solve_fn, {"a": np.linspace(0.1, 2.0, 19), "b": np.linspace(0.1, 2.0, 19)}, chunk_size=2))

    calls_jit = []
    jax.block_until_ready(jax.jit(lambda a: jr.sweep(solve_fn, {"a": a, "b": a}, chunk_size=2,
                                                     progress=lambda d, t: calls_jit.append(int(d))))(
        np.linspace(0.1, 2.0, 19)))
    jax.effects_barrier()
    meta["progress_jit_calls"] = calls_jit

    # 5. equinox runtime errors inside the sharded body: raised for a bad point; the padding
    #    (repeats of the last point) never triggers them
    def checked(x):
        x = eqx.error_if(x, x > 1.0, "point out of range")
        return jnp.sqrt(x)
    ok = jr.sweep(checked, np.linspace(0.0, 1.0, 11), chunk_size=3)
    meta["error_if_ok"] = bool(np.all(np.isfinite(np.asarray(ok))))
    try:
        jax.block_until_ready(jr.sweep(checked, np.linspace(0.0, 1.5, 11), chunk_size=3))
        meta["error_if_raised"] = False
    except Exception as e:
        meta["error_if_raised"] = "point out of range" in str(e)

    np.savez(sys.argv[1], **out)
    with open(sys.argv[2], "w") as fh:
        json.dump(meta, fh)
    '''
)


@pytest.fixture(scope="module")
def child(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sweep8")
    script = tmp / "child.py"
    script.write_text(CHILD)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")])
    env.pop("XLA_FLAGS", None)
    proc = subprocess.run(
        [sys.executable, str(script), str(tmp / "out.npz"), str(tmp / "meta.json")],
        env=env, capture_output=True, text=True, timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    meta = json.loads((tmp / "meta.json").read_text())
    meta["stderr"] = proc.stderr
    return dict(np.load(tmp / "out.npz")), meta


# ------------------------------------------------------------------------------------------
# sharded (8 devices)
# ------------------------------------------------------------------------------------------


def test_grid_sharded_matches_single_device_and_oracle(child):
    out, meta = child
    assert meta["grid_devices"] == 8
    assert meta["grid_shapes"] == {"Gp": [3, 2, 7], "Gpp": [3, 2, 7], "vec": [3, 2, 7, 3]}
    # identical (bitwise) to the single-device path with the same chunk_size
    assert meta["grid_same_single"]
    # plain vmap over the materialised points: different vector widths, same arithmetic;
    # rounding differences of a few ulp at most
    assert meta["grid_vs_vmap_rel"] < 1e-15
    G0, tau, om = np.meshgrid([1e6, 3e6, 5e6], [0.1, 0.25], np.logspace(-2.0, 3.0, 7), indexing="ij")
    g = np_modulus(G0, tau, 1.0, om)
    # numpy vs jax evaluation of the same closed form: rounding only (~1e-16 relative)
    np.testing.assert_allclose(out["grid_Gp"], g.real, rtol=1e-14)
    np.testing.assert_allclose(out["grid_Gpp"], g.imag, rtol=1e-14)
    np.testing.assert_allclose(out["grid_vec"][..., 2], om, rtol=0)  # axis value carried through
    np.testing.assert_allclose(out["grid_vec"][..., 0], g.real, rtol=1e-14)


@pytest.mark.parametrize("n,cs", [(13, 3), (3, 5), (37, 2), (8, 8), (100, 7)])
def test_uneven_sizes_batched_solve(child, n, cs):
    out, meta = child
    (case,) = [c for c in meta["uneven"] if c["n"] == n and c["chunk"] == cs]
    assert case["shape"] == [n]
    assert case["same_single"] and case["same_3"]  # 8 devices == 1 device (== 3 devices), bitwise
    if n == 13:
        assert meta["devices_list_same"] and meta["devices_list_ids"] == [3, 4, 5, 6, 7]
    a, b = np.linspace(0.1, 2.0, n), np.linspace(-1.0, 1.0, n) ** 2
    ref = np.array([np_solve_fn(ai, bi) for ai, bi in zip(a, b)])
    # LAPACK (numpy) vs LAPACK (XLA) on a well-conditioned 3x3 system: rounding, cond ~ 3
    np.testing.assert_allclose(out[f"solve_{n}_{cs}"], ref, rtol=1e-14)


def test_grad_through_sharded_sweep(child):
    out, meta = child
    # same program pieces, different sharding / vector widths: rounding only
    assert meta["grad_vs_single_rel"] < 1e-14
    assert meta["grad_vs_vmap_rel"] < 1e-14
    assert meta["grad_jit_vs_eager_rel"] < 1e-14
    assert meta["grad_no_checkpoint_rel"] < 1e-14  # recomputed forward: same arithmetic
    assert meta["grad_omega_vs_vmap_rel"] < 1e-14
    theta = np.array([3e6, 0.25, 1.0])
    omegas = np.logspace(-2.0, 3.0, 29)
    np.testing.assert_allclose(out["loss"], np_loss(theta, omegas), rtol=1e-14)
    # central finite differences in numpy, step h = 1e-5 |p|: truncation ~ h^2 |f'''| ~ 1e-10,
    # rounding ~ eps |f| / h ~ 1e-11 (relative)
    fd = np.empty(3)
    for k in range(3):
        h = 1e-5 * theta[k]
        tp, tm = theta.copy(), theta.copy()
        tp[k] += h
        tm[k] -= h
        fd[k] = (np_loss(tp, omegas) - np_loss(tm, omegas)) / (2 * h)
    np.testing.assert_allclose(out["grad_theta"], fd, rtol=1e-8)
    # d/d omega_i exactly: d/dw [G''/s + (G'/s)^2] with dG*/dw = i G0 tau f/(1+f) / (1+i w tau/(1+f))^2
    G0, tau, f = theta
    dg = 1j * G0 * tau * (f / (1 + f)) / (1 + 1j * omegas * tau / (1 + f)) ** 2
    g = np_modulus(G0, tau, f, omegas)
    exact = dg.imag / 3e6 + 2 * (g.real / 3e6) * (dg.real / 3e6)
    # rounding in both forms; entries cross zero, so the tolerance is relative to the largest
    np.testing.assert_allclose(out["grad_omega"], exact, rtol=0, atol=1e-13 * np.max(np.abs(exact)))


def test_grad_wrt_grid_axis(child):
    out, _ = child
    # d/dG0 of sum_w G''(w; G0)/s = sum_w G''(w; 1)/s (G'' is linear in G0), exact
    omegas = np.logspace(-2.0, 3.0, 29)
    per_unit = np.sum(np_modulus(1.0, 0.25, 1.0, omegas).imag) / 3e6
    np.testing.assert_allclose(out["grad_G0_axis"], np.full(3, per_unit), rtol=1e-13)


def test_progress_and_jit(child):
    _, meta = child
    # 50 points on 8 devices in chunks of 2: 7 per device -> 4 chunks of 2 per device,
    # reported once per chunk by device 0: 16, 32, 48, 50 (capped at the total)
    assert meta["progress_calls"] == [[16, 50], [32, 50], [48, 50], [50, 50]]
    assert "sweep: chunk 2/2, 50/50 points" in meta["stderr"]
    assert meta["jit_same"]
    # under an outer jit: 19 points, 8 devices, chunks of 2 -> 2 chunks per device: 16, 19
    assert meta["progress_jit_calls"] == [16, 19]


def test_error_if_inside_sharded_sweep(child):
    _, meta = child
    assert meta["error_if_ok"]  # padding repeats a valid point: no spurious error
    assert meta["error_if_raised"]  # a genuinely bad point raises, under shard_map


# ------------------------------------------------------------------------------------------
# single process (this pytest process: one CPU device)
# ------------------------------------------------------------------------------------------


def test_single_device_pytree_points_and_chunking():
    """Points as an equinox Module batch; results independent of chunk_size."""
    mats = jr.StandardLinearSolid(jnp.array([1e6, 2e6, 3e6, 4e6, 5e6]), jnp.full(5, 0.25), jnp.ones(5))
    fn = lambda m: jr.complex_modulus(m, 4.0)
    outs = [jr.sweep(fn, mats, chunk_size=cs) for cs in (1, 2, 3, 5, 100)]
    ref = np_modulus(np.array([1e6, 2e6, 3e6, 4e6, 5e6]), 0.25, 1.0, 4.0)
    for o in outs:
        assert o.shape == (5,) and o.dtype == jnp.complex128
        np.testing.assert_allclose(np.asarray(o), ref, rtol=1e-14)  # rounding only


def test_points_one_after_the_other_equal_the_vectorised_chunks():
    """vectorize=False runs each chunk's points in a lax.map: the numbers of the oracle, and the
    gradient through it (w.r.t. a closed-over G0) equals the vectorised sweep's (rounding only)."""
    mats = jr.StandardLinearSolid(jnp.array([1e6, 2e6, 3e6, 4e6, 5e6]), jnp.full(5, 0.25), jnp.ones(5))
    out = jr.sweep(lambda m: jr.complex_modulus(m, 4.0), mats, chunk_size=2, vectorize=False)
    np.testing.assert_allclose(np.asarray(out), np_modulus(np.array([1e6, 2e6, 3e6, 4e6, 5e6]), 0.25, 1.0, 4.0),
                               rtol=1e-14)

    def total(G0, vectorize):
        m = jr.StandardLinearSolid(G0, 0.25, 1.0)
        return jnp.sum(jr.sweep(lambda w: jr.materials.loss_modulus(m, w), jnp.array([0.5, 4.0, 40.0]),
                                chunk_size=2, vectorize=vectorize))

    np.testing.assert_allclose(float(jax.grad(total)(3e6, False)), float(jax.grad(total)(3e6, True)), rtol=1e-14)


def test_grid_point_and_points_helpers():
    g = jr.Grid({"a": np.arange(3.0)}, b=np.array([10.0, 20.0]))
    assert g.shape == (3, 2) and g.size == 6 and g.names == ("a", "b")
    p = g.point(3)  # row-major: (1, 1)
    assert float(p.a) == 1.0 and float(p.b) == 20.0
    pts = g.points()
    np.testing.assert_array_equal(np.asarray(pts.a), [0, 0, 1, 1, 2, 2])
    np.testing.assert_array_equal(np.asarray(pts.b), [10, 20, 10, 20, 10, 20])
    res = jr.sweep(lambda p: p.a * p.b, g, chunk_size=4)
    np.testing.assert_array_equal(np.asarray(res), np.outer(np.arange(3.0), [10.0, 20.0]))
    # a list of numbers is one axis; a pytree axis (batch of materials) is one axis
    mats = jr.StandardLinearSolid(jnp.array([1e6, 2e6]), jnp.array([0.1, 0.2]), jnp.array([1.0, 2.0]))
    g2 = jr.Grid(material=mats, omega=[1.0, 10.0, 100.0])
    assert g2.shape == (2, 3)
    res = jr.sweep(lambda p: jr.complex_modulus(p.material, p.omega), g2)
    ref = np_modulus(np.array([1e6, 2e6])[:, None], np.array([0.1, 0.2])[:, None], np.array([1.0, 2.0])[:, None],
                     np.array([1.0, 10.0, 100.0])[None, :])
    np.testing.assert_allclose(np.asarray(res), ref, rtol=1e-14)  # rounding only


def test_bad_input_raises():
    with pytest.raises(ValueError, match="disagree"):
        jr.sweep(lambda p: p["a"], {"a": np.ones(3), "b": np.ones(4)})
    with pytest.raises(ValueError, match="scalar leaf"):
        jr.sweep(lambda p: p, np.float64(1.0))
    with pytest.raises(ValueError, match="empty"):
        jr.sweep(lambda p: p, np.ones(0))
    with pytest.raises(ValueError, match="chunk_size"):
        jr.sweep(lambda p: p, np.ones(3), chunk_size=0)
    with pytest.raises(ValueError, match="devices"):
        jr.sweep(lambda p: p, np.ones(3), devices=jax.device_count() + 1)
    with pytest.raises(ValueError, match="1D"):
        jr.Grid(a=np.ones((2, 2)))
    with pytest.raises(ValueError, match="identifiers"):
        jr.Grid({"not a name": np.ones(2)})
    with pytest.raises(ValueError, match="empty"):
        jr.Grid(a=np.ones(0))
    # a NaN on an axis or in points: one line on the host (before, a callback dump from inside the
    # swept function's program); inf stays (a half-space H)
    with pytest.raises(ValueError, match=r"^grid axis 'V' holds a NaN at index 1$"):
        jr.Grid(V=np.array([0.01, np.nan]), P=np.array([100.0]))
    with pytest.raises(ValueError, match=r"^points holds a NaN at index 2$"):
        jr.sweep(lambda p: p, np.array([1.0, 2.0, np.nan]))
    assert jr.Grid(H=np.array([0.01, np.inf])).shape == (2,)


def test_multihost_example_two_processes():
    """benchmarks/multihost_example.py: 2 processes x 2 CPU devices via jax.distributed
    (coordinator and gloo collectives on 127.0.0.1) reproduce the single-process result
    bitwise; the grid is 11 x 37 = 407 points, uneven over 4 devices (~2-3 s)."""
    proc = subprocess.run(
        [sys.executable, str(REPO / "benchmarks" / "multihost_example.py"), "--launch-local", "2"],
        capture_output=True, text=True, timeout=120, env={k: v for k, v in os.environ.items() if k != "XLA_FLAGS"},
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "OK: 2 processes" in proc.stdout
