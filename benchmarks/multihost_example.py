"""Multi-host sweep with ``jax.distributed``: a runnable example of ``jaxroll.sweep``.

The same script runs on every host (process). Each process calls
``jax.distributed.initialize`` before any other JAX call; afterwards ``jax.devices()`` lists
the devices of *all* processes, ``jaxroll.sweep`` shards the grid over all of them and returns
the result replicated on every device, so each process reads all of it with ``np.asarray``.

Usage
-----
Single process (no ``jax.distributed``; a smoke test of the same code path)::

    python benchmarks/multihost_example.py

Two CPU processes on this machine, launched by the script itself (each process gets
``--local-devices`` forced host devices; the result is checked against a single-process run)::

    python benchmarks/multihost_example.py --launch-local 2

Real cluster, one command per host (host 0 runs the coordinator; any free port)::

    python benchmarks/multihost_example.py --coordinator host0:12355 --num-processes 4 --process-id 0
    python benchmarks/multihost_example.py --coordinator host0:12355 --num-processes 4 --process-id 1
    ...

On SLURM / Open MPI / Cloud TPU, ``jax.distributed.initialize()`` with no arguments detects
these settings itself: pass ``--auto``.

``--model direct`` sweeps the real front door (``jr.rolling_resistance(method=jr.Direct())``,
sphere R = 2 cm, P = 100 N, H = 5 mm) instead of the cheap loss-tangent stand-in; ``--quick``
shrinks the grid to 7 speeds x 3 moduli.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without install

def _parse():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--coordinator", help="host:port of process 0 (jax.distributed coordinator)")
    ap.add_argument("--num-processes", type=int, default=1)
    ap.add_argument("--process-id", type=int, default=0)
    ap.add_argument("--auto", action="store_true", help="jax.distributed.initialize() with cluster auto-detection")
    ap.add_argument("--local-devices", type=int, default=2, help="forced CPU devices per process (CPU only)")
    ap.add_argument("--launch-local", type=int, metavar="N", help="spawn N processes on localhost and check them")
    ap.add_argument("--n-speeds", type=int, default=37)
    ap.add_argument("--n-moduli", type=int, default=11)
    ap.add_argument("--points", action="store_true", help="sweep the grid as a flat point list instead")
    ap.add_argument("--model", choices=("tan_delta", "direct"), default="tan_delta",
                    help="swept function: loss-tangent stand-in or jr.rolling_resistance(method=jr.Direct())")
    ap.add_argument("--quick", action="store_true", help="7 speeds x 3 moduli")
    ap.add_argument("--out", help="write the gathered result (process 0) to this .npy file")
    args = ap.parse_args()
    if args.quick:
        args.n_speeds, args.n_moduli = 7, 3
    return args


def launch_local(args) -> int:
    """Start ``args.launch_local`` copies of this script on localhost and compare with one process."""
    import socket

    with socket.socket() as s:  # a free port for the coordinator
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    import tempfile

    tmp = tempfile.mkdtemp(prefix="jaxroll_multihost_")
    common = [sys.executable, __file__, "--local-devices", str(args.local_devices),
              "--n-speeds", str(args.n_speeds), "--n-moduli", str(args.n_moduli), "--model", args.model]
    if args.points:
        common.append("--points")
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    procs = [
        subprocess.Popen(
            common + ["--coordinator", f"127.0.0.1:{port}", "--num-processes", str(args.launch_local),
                      "--process-id", str(i), "--out", os.path.join(tmp, f"multi{i}.npy")],
            env=env,
        )
        for i in range(args.launch_local)
    ]
    try:
        single = subprocess.run(common + ["--out", os.path.join(tmp, "single.npy")], env=env, timeout=90)
        codes = [p.wait(timeout=90) for p in procs]
    except subprocess.TimeoutExpired:
        for p in procs:  # never leave the processes we started behind
            p.kill()
        print("FAILED: timed out after 90 s")
        return 1
    if single.returncode or any(codes):
        print(f"FAILED: return codes {codes}, single {single.returncode}")
        return 1
    import numpy as np

    ref = np.load(os.path.join(tmp, "single.npy"))
    for i in range(args.launch_local):
        got = np.load(os.path.join(tmp, f"multi{i}.npy"))
        if not np.array_equal(got, ref):
            print(f"FAILED: process {i} result differs from the single-process result "
                  f"(max |diff| {np.max(np.abs(got - ref))})")
            return 1
    print(f"OK: {args.launch_local} processes x {args.local_devices} devices reproduce the "
          f"single-process result exactly ({ref.shape})")
    return 0


def main() -> int:
    args = _parse()
    if args.launch_local:
        return launch_local(args)

    # Forced host devices only matter on CPU (tests/examples); on GPU/TPU hosts drop this.
    os.environ.setdefault("XLA_FLAGS", f"--xla_force_host_platform_device_count={args.local_devices}")
    import jax

    # 1. jax.distributed.initialize must come before any other JAX call.
    if args.auto:
        jax.distributed.initialize()
    elif args.num_processes > 1:
        jax.distributed.initialize(
            coordinator_address=args.coordinator, num_processes=args.num_processes, process_id=args.process_id
        )

    import jax.numpy as jnp
    import numpy as np

    import jaxroll as jr

    pid = jax.process_index()
    print(f"[process {pid}/{jax.process_count()}] local devices {jax.local_device_count()}, "
          f"global devices {jax.device_count()}", flush=True)

    # 2. Every process builds the same grid (same values, same order).
    grid = jr.Grid(
        G0=jnp.linspace(1e6, 5e6, args.n_moduli),   # relaxed modulus [Pa]
        V=jnp.logspace(-4.0, 0.0, args.n_speeds),   # speed [m/s]
    )

    # 3. The swept function: a cheap stand-in (loss tangent at the frequency V/a of a 1 mm
    #    contact) or the real front door with the direct method.
    def fn(p):
        material = jr.StandardLinearSolid(p.G0, 0.25, 1.0)
        if args.model == "direct":
            return jr.rolling_resistance(material, jr.Layer(5e-3), radius=0.02, load=100.0, speed=p.V,
                                         method=jr.Direct(), throw=False).value
        return jr.materials.tan_delta(material, p.V / 1e-3)

    t0 = time.perf_counter()
    if args.points:  # the same points as a flat list (pytree with a leading axis)
        out = jr.sweep(fn, grid.points(), chunk_size=16)
    else:  # sharded over jax.devices(): the devices of all processes
        out = jr.sweep(fn, grid, chunk_size=16)
    # 4. The result is replicated over all devices of all processes: every process reads it.
    full = np.asarray(out).reshape(grid.shape)
    dt = time.perf_counter() - t0
    print(f"[process {pid}] result {full.shape}, {grid.size} points in {dt:.2f} s "
          f"(incl. compile), max {'R_r' if args.model == 'direct' else 'tan delta'} {full.max():.6f}", flush=True)
    if args.out:
        np.save(args.out, full)
    if jax.process_count() > 1:
        jax.distributed.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
