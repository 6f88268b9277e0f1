"""XLA compile options of jaxroll's own top-level programs (CPU only).

jaxroll's programs are bound by compilation on a first call (seconds for a full-model point,
hundreds of small kernels each costing XLA:CPU's LLVM pipeline about the same). One XLA:CPU
option shortens that without slowing the programs (measured by
``benchmarks/compile_options.py``, benchmarks/LOG.md):

* ``xla_backend_optimization_level=2``: LLVM's ``-O2`` instead of ``-O3``.

(``xla_cpu_use_fusion_emitters=False``, XLA's element-wise emitters, would shorten compilation
further, but a layer with inertia's integrals then run twice as long: a default sphere point on
a 30 mm layer with rho = 1000 kg/m^3 took 105 ms per call instead of 52 ms.)

They are *per-program* options (``jax.jit(...).lower(...).compile(options)``): they apply to the
executables jaxroll compiles itself (the front doors called eagerly and the fits' evaluations,
through :func:`jaxroll._compilation_cache.call`, stored or compiled in the process; the maps' and
buckets' ahead-of-time programs; ``jaxroll reproduce``'s), never to
the user's other programs, and never to a program the user traces (inside a user's ``jax.jit``,
``jax.grad`` or ``jax.vmap``, jaxroll's functions are part of the user's program, whose options
are the user's: JAX allows options on the top-level program only). A user who compiles such a
program may pass :func:`compiler_options` themselves:
``jax.jit(f, compiler_options=jaxroll.compiler_options())``.

The numbers change by rounding only (a different order of floating-point operations: relative
differences of 1e-15..1e-13 measured, against the solvers' tolerance of 1e-10); no option that
changes semantics (fast min/max, fast math) is set. The environment variable
``JAXROLL_XLA_OPTIONS=0`` (or ``off``, ``false``, ``no``) switches them off, for comparison or
where an XLA version rejects them; an option that the process's ``XLA_FLAGS`` sets keeps the
process's value (the test suite compiles at ``--xla_backend_optimization_level=0``). Other
platforms get none (the GPU compiler has its own pipeline; these choices were measured on CPU).
"""

from __future__ import annotations

import os

__all__ = ["CPU_OPTIONS", "ENV_VAR", "compiler_options"]

#: Environment variable: ``0``/``off``/``false``/``no`` switches the options off.
ENV_VAR = "JAXROLL_XLA_OPTIONS"

#: The options of jaxroll's programs on the CPU platform (see the module docstring).
CPU_OPTIONS = {"xla_backend_optimization_level": 2}

_OFF = ("0", "off", "false", "no")


def compiler_options(platform: str | None = None, environ=None) -> dict | None:
    """The XLA compile options jaxroll gives its own programs on ``platform`` (default: JAX's
    default backend): a new dict, or ``None`` where there are none (not CPU, the switch
    ``JAXROLL_XLA_OPTIONS=0``, or every option already set by the process's ``XLA_FLAGS``,
    which keep their values; ``environ``: default ``os.environ``).

    A program the user compiles around jaxroll's functions (a jitted gradient, a table under
    ``jax.jit``) is the user's, with XLA's defaults; it compiles faster and runs as fast with
    these options, given to the top-level ``jax.jit`` (JAX takes options there only)::

        grad = jax.jit(jax.grad(loss), compiler_options=jaxroll.compiler_options())

    Measured compile and run times with and without them: ``benchmarks/compile_options.py``
    (benchmarks/README.md, "Compile options"); the numbers change by rounding only."""
    environ = os.environ if environ is None else environ
    if environ.get(ENV_VAR, "").strip().lower() in _OFF:
        return None
    if platform is None:
        import jax

        platform = jax.default_backend()
    if platform != "cpu":
        return None
    # an option the process sets in XLA_FLAGS stays the process's (e.g. the test suite's lighter level)
    flags = environ.get("XLA_FLAGS", "")
    options = {k: v for k, v in CPU_OPTIONS.items() if f"--{k}=" not in flags and f"--{k} " not in f"{flags} "}
    return options or None
