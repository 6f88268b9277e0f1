"""What XLA:CPU's compile flags cost and save: compile and run CPU seconds of two typical programs.

    python benchmarks/xla_flags.py

The test suite is bound by compilation (tests/_xla.py chooses its flags from this). Each flag set
runs in its own interpreter (``XLA_FLAGS`` is read when jax starts), without the persistent
compilation cache. Programs, both compiled ahead of time with ``jax.jit(...).lower().compile()``:

- ``slices-grad``: the value and G0-gradient of the SP slices on a 16-cell line window (1 mm
  cells, 0.1 m period), sphere R = 20 mm on a 30 mm layer, 100 N, 10 mm/s;
- ``full-point``: the full 3D model at the same point on a 29-cell window of 0.5 mm cells (200
  Fourier terms).

Reported: CPU seconds (user + system of the process: steady on a shared machine) of the compile,
and of one run (the median of 5 after a warm-up).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

FLAG_SETS = {
    "XLA defaults": "",
    "element-wise emitters": "--xla_cpu_use_fusion_emitters=false",
    "element-wise emitters, LLVM level 1": "--xla_cpu_use_fusion_emitters=false --xla_backend_optimization_level=1",
    "LLVM level 0": "--xla_backend_optimization_level=0",
    "element-wise emitters, LLVM level 0": "--xla_cpu_use_fusion_emitters=false --xla_backend_optimization_level=0",
}

CHILD = r"""
import json, statistics, time, jax
import jaxroll as jr

def slices(G0, V):
    m = jr.StandardLinearSolid(G0, 0.25, 1.0)
    return jr.rolling_resistance(m, jr.Layer(0.03), radius=0.02, load=100.0, speed=V, throw=False,
                                 method=jr.Slices("SP", grid=jr.FixedGrid(1e-3, 16, period=0.1))).value

def full(G0, V):
    m = jr.StandardLinearSolid(G0, 0.25, 1.0)
    return jr.rolling_resistance(m, jr.Layer(0.03), radius=0.02, load=100.0, speed=V, throw=False,
                                 method=jr.Full(grid=jr.FixedGrid(5e-4, 29, period=0.1, n_terms=200))).value

out = {}
for name, fn in (("slices-grad", jax.value_and_grad(slices)), ("full-point", full)):
    lowered = jax.jit(fn).trace(3e6, 0.01).lower()
    c0 = time.process_time()
    compiled = lowered.compile()
    compile_s = time.process_time() - c0
    jax.block_until_ready(compiled(3e6, 0.01))
    runs = []
    for _ in range(5):
        c0 = time.process_time()
        jax.block_until_ready(compiled(3e6, 0.01))
        runs.append(time.process_time() - c0)
    out[name] = [compile_s, statistics.median(runs)]
print(json.dumps(out))
"""


def main():
    print(f"{'flags':40s} {'slices-grad compile / run':>28s} {'full-point compile / run':>28s}")
    for label, flags in FLAG_SETS.items():
        env = dict(os.environ, XLA_FLAGS=flags, JAXROLL_COMPILATION_CACHE="0", TF_CPP_MIN_LOG_LEVEL="3",
                   PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
        proc = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=True)
        res = json.loads(proc.stdout.strip().splitlines()[-1])
        cells = [f"{res[k][0]:8.2f} s / {1e3 * res[k][1]:6.1f} ms" for k in ("slices-grad", "full-point")]
        print(f"{label:40s} {cells[0]:>28s} {cells[1]:>28s}", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
