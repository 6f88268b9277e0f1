"""Test configuration: float64 everywhere, strict dtype promotion, and a suite that compiles less.

The suite is bound by XLA compilation, not by running programs (a slice call compiles in seconds
and then runs in milliseconds). Settings made here before jax starts cut that time for the
tests and for every subprocess they start (README blocks, CLI commands, notebook kernels), which
inherit the environment:

- Opt-in (``JAXROLL_TEST_XLA_O0=1``): ``--xla_backend_optimization_level=0``, XLA:CPU without
  LLVM's optimisation passes. Compile-bound files compile a quarter to a third faster, but
  run-bound programs run up to 2x slower or worse, so it is not the default.
- One persistent compilation cache per test session (a temporary folder, removed at the end):
  a program compiled once is loaded, not recompiled, when another test module (after
  ``jax.clear_caches`` below), a rebuilt ``jax.jit(lambda ...)`` or a subprocess lowers the same
  program again. Programs with host callbacks (``jax.debug.callback``) are not stored.

Set ``JAXROLL_TEST_PLAIN_XLA=1`` to run with jax's defaults (no flag, no cache), for comparison.
"""

import gc
import os
import shutil
import tempfile

if not os.environ.get("JAXROLL_TEST_PLAIN_XLA"):
    if os.environ.get("JAXROLL_TEST_XLA_O0"):  # opt-in: see the module docstring
        os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} --xla_backend_optimization_level=0".strip()
    # XLA:CPU logs three lines per program it loads from a persistent cache on some x86 CPUs
    # ("Loading XLA:CPU AOT result ... prefer-no-gather", an upstream XLA message): keep them out
    # of the subprocesses' stderr that CLI tests read
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "3")
    if "JAX_COMPILATION_CACHE_DIR" not in os.environ:
        _CACHE_DIR = tempfile.mkdtemp(prefix="jaxroll-tests-xla-")
        os.environ["JAX_COMPILATION_CACHE_DIR"] = _CACHE_DIR
        os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0"
        os.environ["JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES"] = "-1"

import jax  # noqa: E402  (after the environment above)
import pytest  # noqa: E402

import jaxroll  # noqa: E402, F401  (enables float64)

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")


def pytest_sessionfinish(session, exitstatus):
    cache = globals().get("_CACHE_DIR")
    if cache:
        shutil.rmtree(cache, ignore_errors=True)


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    """Drop jax's compiled programs after each test module.

    Every compiled XLA:CPU program keeps a few memory mappings for its code; a process that runs
    the whole suite accumulated them until the kernel's limit (``vm.max_map_count``, 65530 here)
    and XLA aborted inside a compile ("Fatal Python error: Aborted", no message) near the end of
    the suite. A program that a later module needs again comes back from the session's
    persistent compilation cache (above) instead of being compiled again."""
    yield
    jax.clear_caches()
    gc.collect()
    if os.environ.get("JAXROLL_TEST_MAPS"):
        with open(f"/proc/{os.getpid()}/maps") as fh, open(os.environ["JAXROLL_TEST_MAPS"], "a") as out:
            out.write(f"{sum(1 for _ in fh)}\n")
