"""JAX's persistent compilation cache, switched on by ``import jaxroll``.

A fresh process spends seconds compiling the program of its first call (the contact solvers are
large programs). With the persistent cache, JAX stores each compiled program on disk and a
later process loads it instead of compiling it again; tracing the Python code still happens.

* Directory: ``$XDG_CACHE_HOME/jaxroll/jax`` (``~/.cache/jaxroll/jax`` when ``XDG_CACHE_HOME``
  is unset), or the directory named by the environment variable ``JAXROLL_COMPILATION_CACHE``;
  in it, one subdirectory per processor type (:func:`processor_tag`): a compiled CPU program
  uses the instruction set of the machine that compiled it, and a home directory may be shared
  by different machines.
* ``JAXROLL_COMPILATION_CACHE=0`` (or ``off``, ``false``, ``no``) switches it off: nothing is
  written.
* A cache directory already set for JAX (``JAX_COMPILATION_CACHE_DIR``, or
  ``jax.config.update("jax_compilation_cache_dir", ...)`` before ``import jaxroll``) is left
  as it is, together with JAX's other cache settings.
* Programs that took at least :data:`MIN_COMPILE_TIME` to compile are stored, about 1 MB each
  (one per method, geometry and input shapes, and per JAX version); the directory is not
  trimmed (JAX's size cap needs the ``filelock`` package) and may be deleted at any time.
* It takes effect if ``import jaxroll`` comes before the process's first compilation (JAX
  decides once per process whether it uses the cache).
* On some x86 processors XLA logs three lines for each program it loads from the cache
  ("Loading XLA:CPU AOT result. Target machine feature +prefer-no-gather is not supported on
  the host machine"): its check counts LLVM tuning preferences as processor features. The
  program was compiled on this processor type (the subdirectory above). ``import jaxroll``
  before JAX sets ``TF_CPP_MIN_LOG_LEVEL=3`` when it is unset, which hides the lines; a process
  that imports JAX first sets it itself.

Only programs without host callbacks can be stored (a JAX rule): the front doors keep theirs
free of callbacks when the inputs are concrete (see :mod:`jaxroll.rolling`).
"""

from __future__ import annotations

import hashlib
import os
import platform
from pathlib import Path

import jax

__all__ = ["ENV_VAR", "MIN_COMPILE_TIME", "cache_directory", "enable", "processor_tag"]

#: Environment variable: ``0``/``off``/``false``/``no`` switches the cache off, any other
#: non-empty value is the cache directory.
ENV_VAR = "JAXROLL_COMPILATION_CACHE"

#: Shortest compile time [s] of a program worth storing: the front doors' programs take seconds;
#: the grid rule's helper programs (contact-size estimate, regime, error table) 0.1-0.5 s each,
#: and with them stored a second process sizes a default sphere grid in 0.38 s of CPU instead of
#: 1.65 s (measured 2026-11-26, 2 shared cores); jax's eager one-operation programs (0.01-0.09 s)
#: stay out, each stored program costing a file read.
MIN_COMPILE_TIME = 0.1

_OFF = ("0", "off", "false", "no")


def processor_tag() -> str:
    """A short name of this machine's processor type: its architecture and a hash of its
    instruction-set flags (``/proc/cpuinfo``; the processor name elsewhere)."""
    flags = platform.processor()
    try:
        with open("/proc/cpuinfo") as fh:
            flags = next((line for line in fh if line.startswith(("flags", "Features"))), flags)
    except OSError:
        pass
    return f"{platform.machine() or 'cpu'}-{hashlib.sha1(flags.encode()).hexdigest()[:12]}"


def cache_directory(environ=None) -> Path | None:
    """The directory jaxroll gives JAX's persistent compilation cache (a
    :func:`processor_tag` subdirectory of the cache directory), or ``None`` when
    ``JAXROLL_COMPILATION_CACHE`` switches it off (``environ``: default ``os.environ``)."""
    environ = os.environ if environ is None else environ
    value = environ.get(ENV_VAR, "").strip()
    if value.lower() in _OFF:
        return None
    if value and value.lower() not in ("1", "on", "true", "yes"):
        return Path(value).expanduser() / processor_tag()
    base = environ.get("XDG_CACHE_HOME", "").strip() or Path("~/.cache").expanduser()
    return Path(base) / "jaxroll" / "jax" / processor_tag()


def enable(environ=None) -> Path | None:
    """Point JAX's persistent compilation cache at :func:`cache_directory` (unless off, or a
    directory is set for JAX already) and return the directory in use (``None``: no cache).
    JAX creates the directory when it first stores a program."""
    current = jax.config.jax_compilation_cache_dir
    if current:
        return Path(current)
    directory = cache_directory(environ)
    if directory is None:
        return None
    jax.config.update("jax_compilation_cache_dir", str(directory))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_COMPILE_TIME)
    return directory
