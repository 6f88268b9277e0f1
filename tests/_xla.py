"""XLA:CPU compile flags of the test suite (imported by tests/conftest.py before jax starts).

The suite is bound by XLA compilation: thousands of programs, each run a few times. Measured by
``python benchmarks/xla_flags.py`` (CPU seconds; benchmarks/LOG.md, "What the default test suite
costs"): a slice program's value and gradient compiles in 4.1 s with XLA's defaults, 2.4 s with
:data:`XLA_COMPILE_FAST` and 1.1 s with :data:`XLA_LIGHT` as well; a coarse full 3D point
compiles in 4.2 / 3.1 / 0.9 s and runs in 7 / 7 / 13 ms.
"""

import os

#: XLA:CPU's element-wise IR emitters instead of its newer fusion emitters: programs compile a
#: third faster and run as fast. Every test process and every interpreter the tests start.
XLA_COMPILE_FAST = "--xla_cpu_use_fusion_emitters=false"
#: Without LLVM's optimisation passes as well: compiling takes half as long again, programs run up
#: to 2x slower. For the test processes and the interpreters whose programs run a few points each
#: (notebook kernels, README blocks, CLI commands), not for run-bound ones (the docs' ``jaxroll
#: fit`` commands, notebook 03's fits: 42.6 -> 63.9 s of CPU with it). Not to be confused with
#: ``jax_disable_most_optimizations``, which also switches off LLVM's expensive passes: there a
#: run-bound test (test_direct's periodic gradient) went from 4 s to more than 250 s.
XLA_LIGHT = "--xla_backend_optimization_level=0"
#: Set to 1 to keep XLA's defaults everywhere (for comparison).
DEFAULT_ENV = "JAXROLL_TEST_XLA_DEFAULT"


def default_xla_flags(flags: str | None) -> str:
    """``flags`` (an ``XLA_FLAGS`` value) for a run-bound process: with :data:`XLA_COMPILE_FAST`,
    without an optimisation level and without a forced host device count that another test may
    have set."""
    kept = [f for f in (flags or "").split()
            if not any(k in f for k in ("device_count", "optimization_level", "fusion_emitters"))]
    return " ".join(kept if os.environ.get(DEFAULT_ENV) else [*kept, XLA_COMPILE_FAST])


def light_xla_flags(flags: str | None) -> str:
    """``flags`` for a compile-bound process: :func:`default_xla_flags` and :data:`XLA_LIGHT`."""
    return " ".join(filter(None, [default_xla_flags(flags), "" if os.environ.get(DEFAULT_ENV) else XLA_LIGHT]))
