"""Test configuration: float64 everywhere and strict dtype promotion."""

import jax

import jaxroll  # noqa: F401  (enables float64)

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")
