"""Test configuration: float64 everywhere and strict dtype promotion."""

import gc
import os

import jax
import pytest

import jaxroll  # noqa: F401  (enables float64)

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    """Drop jax's compiled programs after each test module.

    Every compiled XLA:CPU program keeps a few memory mappings for its code; a process that runs
    the whole suite accumulated them until the kernel's limit (``vm.max_map_count``, 65530 here)
    and XLA aborted inside a compile ("Fatal Python error: Aborted", no message) near the end of
    the suite. Modules rarely share programs, so clearing between modules costs little."""
    yield
    jax.clear_caches()
    gc.collect()
    if os.environ.get("JAXROLL_TEST_MAPS"):
        with open(f"/proc/{os.getpid()}/maps") as fh, open(os.environ["JAXROLL_TEST_MAPS"], "a") as out:
            out.write(f"{sum(1 for _ in fh)}\n")
