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
  trimmed and may be deleted at any time. (JAX's own size cap, ``jax_compilation_cache_max_size``,
  keeps an access-time file beside each program and fails to write any program into a directory
  filled without it, e.g. by an earlier jaxroll: it is left off.)
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

JAX's cache keeps compiled programs, so a new process still traces and lowers the Python code
before it finds one (about a second for a full-model point). :func:`call` removes that step for
the front doors and the automatic grid's sizing programs: it stores each one's lowered program
(StableHLO, ``jax.export``) in :data:`PROGRAMS` inside the cache directory, one file per static
configuration and input shapes, and a later process loads it and compiles it, which JAX's cache
then finds. The folder is kept under :data:`MAX_LOWERED_BYTES`: storing a program removes the
least recently used ones beyond it (a loaded file counts as used). The key of a file holds everything the lowered program depends on: jaxroll's source
files, the versions of JAX, jaxlib, equinox, NumPy, SciPy and Python, JAX's platform and tracing
settings (``jax_enable_x64``, dtype promotion, ...), the function, the exact text of every static
argument and pytree node (fully qualified types; a value without an exact text, e.g. a function,
is not stored), and the shapes, dtypes and weak types of the array inputs. The numbers are those
of the traced program bit for bit (the same StableHLO, compiled the same way: a top-level program
with jaxroll's XLA options, :mod:`jaxroll._xla_options`; a program that cannot be stored is
compiled so too, in the process, and so is every program with the cache off). Calls under a
user's ``jit``/``vmap``/``grad`` (traced inputs, or any trace under way) run the function itself,
so transformations see the original program. A file that is absent, unreadable or of another
key is written anew; a stored program that does not run leaves the function to run itself.
The files are Python pickles: the cache directory must be as trusted as the code that reads it
(as JAX's own cache is).
"""

from __future__ import annotations

import hashlib
import os
import platform
import re
import threading
from pathlib import Path

import jax

from ._xla_options import compiler_options

__all__ = ["ENV_VAR", "MAX_LOWERED_BYTES", "MIN_COMPILE_TIME", "cache_directory", "compiled", "enable",
           "processor_tag"]

#: Environment variable: ``0``/``off``/``false``/``no`` switches the cache off, any other
#: non-empty value is the cache directory.
ENV_VAR = "JAXROLL_COMPILATION_CACHE"

#: Shortest compile time [s] of a program worth storing: the front doors' programs take seconds;
#: the grid rule's helper programs (contact-size estimate, regime, error table) 0.1-0.5 s each,
#: and with them stored a second process sizes a default sphere grid in 0.38 s of CPU instead of
#: 1.65 s (measured 2026-11-26, 2 shared cores); jax's eager one-operation programs (0.01-0.09 s)
#: stay out, each stored program costing a file read.
MIN_COMPILE_TIME = 0.1

#: Size cap [bytes] of the lowered programs' folder :data:`PROGRAMS` (10-300 kB per program;
#: every edit of jaxroll's source or new JAX version writes new ones).
MAX_LOWERED_BYTES = 64 << 20

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


# ---- traced programs across processes ---------------------------------------------------------
#
# JAX's cache stores compiled programs, but a new process still traces and lowers the Python code
# (about a second for a full-model point) before it can look the program up. ``call`` skips that:
# it stores the lowered program (StableHLO, ``jax.export``) of a function for one static
# configuration and input shapes, and a later process loads it, so that only the stored program is
# compiled, which JAX's cache then finds.

#: Subdirectory of the compilation cache directory that holds the lowered programs.
PROGRAMS = "jaxroll-lowered"

_FORMAT = 2  # of the stored files; part of every key
_memo: dict = {}  # (function, input structure, static leaves, shapes, trace context) -> (run, output structure)
_ahead: dict = {}  # memo key -> the thread compiling its program ahead (compile_ahead)
_ahead_lock = threading.Lock()  # compile_ahead may run in a thread of its own (a fit's window forecast)
_prefix: list = []  # the key's part common to every program of this process (computed once)


class _NotPlain(Exception):
    """A static value whose text would not identify it (a function, an object of unknown type)."""


def _canon(x) -> str:
    """A text that determines the static value ``x`` (the same text, the same value); raises
    :class:`_NotPlain` for values whose text may not (then the program is not stored)."""
    import dataclasses
    import enum

    import numpy as np

    if isinstance(x, enum.Enum):
        return f"{_qualname(type(x))}.{x.name}"
    if x is None or type(x) in (bool, int, float, complex, str, bytes):
        return f"{type(x).__name__}:{x!r}"
    if isinstance(x, (tuple, list)):
        return f"{type(x).__name__}({','.join(_canon(v) for v in x)})"
    if isinstance(x, dict):
        return "dict(" + ",".join(f"{_canon(k)}={_canon(v)}" for k, v in x.items()) + ")"
    if isinstance(x, frozenset):
        return "frozenset(" + ",".join(sorted(_canon(v) for v in x)) + ")"
    if isinstance(x, type):
        return f"type:{_qualname(x)}"
    if isinstance(x, np.dtype):
        return f"dtype:{x.str}"
    if isinstance(x, np.generic):
        return f"{x.dtype.str}:{x.item()!r}"
    if type(x).__name__ == "_Missing" and type(x).__module__.startswith("equinox"):
        return "MISSING"
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return f"{_qualname(type(x))}(" + ",".join(
            f"{f.name}={_canon(getattr(x, f.name, None))}" for f in dataclasses.fields(x)) + ")"
    raise _NotPlain(type(x))


def _qualname(t: type) -> str:
    if "<locals>" in t.__qualname__:
        raise _NotPlain(t)
    return f"{t.__module__}.{t.__qualname__}"


def _structure(treedef) -> str:
    """The text of a pytree structure: every node's type (fully qualified) and static data."""
    out, stack = [], [treedef]
    while stack:
        t = stack.pop()
        data = t.node_data()
        children = t.children()
        out.append("*" if data is None else f"{_qualname(data[0])}[{_canon(data[1])}]/{len(children)}")
        stack.extend(reversed(children))
    return ";".join(out)


def _key_prefix() -> str:
    """What every program's key shares: the stored format, the versions of the code that is
    traced (jaxroll's source files, JAX, jaxlib, equinox, NumPy, SciPy) and JAX's platform."""
    if not _prefix:
        import importlib.util
        import sys

        import equinox
        import jaxlib
        import numpy

        source = hashlib.sha256()
        for path in sorted(Path(__file__).parent.rglob("*.py")):
            source.update(str(path.relative_to(Path(__file__).parent)).encode() + b"\0" + path.read_bytes())
        # SciPy computes some of the programs' constants on the host; its version file, read
        # without importing SciPy (a loaded program needs only its LAPACK, if any: _prepare_custom_calls)
        spec = importlib.util.find_spec("scipy")
        scipy_version = Path(spec.origin).with_name("version.py").read_text() if spec and spec.origin else ""
        versions = (jax.__version__, jaxlib.__version__, equinox.__version__, numpy.__version__, scipy_version,
                    sys.version)
        _prefix.append(f"{_FORMAT}|{source.hexdigest()}|{versions}|{jax.default_backend()}|{processor_tag()}")
    return _prefix[0]


def programs_directory() -> Path | None:
    """Where :func:`call` stores lowered programs: :data:`PROGRAMS` in JAX's compilation cache
    directory; ``None`` (nothing stored, nothing read) when ``JAXROLL_COMPILATION_CACHE`` switches
    the cache off, JAX has no local cache directory, or JAX's cache is disabled."""
    if os.environ.get(ENV_VAR, "").strip().lower() in _OFF:
        return None
    directory = jax.config.jax_compilation_cache_dir
    if not directory or "://" in directory or not jax.config.jax_enable_compilation_cache:
        return None
    return Path(directory) / PROGRAMS


def call(fn, *args, store: bool = True):
    """``fn(*args)``, with ``fn`` a jitted function (``jax.jit`` or ``equinox.filter_jit``) whose
    non-array arguments are static, through a lowered program kept across processes: the first
    process to call ``fn`` with a static configuration and input shapes stores the program
    (:func:`programs_directory`); later processes load and run it instead of tracing ``fn``. The
    numbers are those of ``fn`` (the same program). ``fn`` itself runs when an input is traced
    or the call is part of a user's ``jit``/``vmap``/``grad``, or when neither the cache nor
    compile options apply; with the cache off, or for a static value without an identifying text,
    ``fn`` compiles in the process as a top-level program with jaxroll's compile options.
    ``store=False``: never stored (only compiled with the options): for large programs whose export
    costs more in the first process than tracing saves in later ones (a fit's evaluation;
    benchmarks/LOG.md). Only for jaxroll's own functions: the key holds jaxroll's source, not the caller's."""
    if programs_directory() is None and compiler_options() is None:
        return fn(*args)
    leaves, treedef = jax.tree_util.tree_flatten(args)
    if not _outside_traces() or any(isinstance(x, jax.core.Tracer) for x in leaves):
        return fn(*args)
    dynamic, memo_key = _memo_key(fn, leaves, treedef)
    if memo_key is None:  # an unhashable static value: fn's own jit would refuse it too
        return fn(*args)
    with _ahead_lock:  # (compile_ahead enters a program in both dicts at once)
        ahead = _ahead.pop(memo_key, None)
    if ahead is not None:  # compiled ahead (compile_ahead): wait for it instead of compiling it twice
        ahead.join()
    entry = _memo.get(memo_key)
    if entry is None:
        shapes = memo_key[3]
        entry = (store and _lowered(fn, leaves, treedef, dynamic, shapes)) or _in_process(fn, leaves, treedef, dynamic)
        _memo[memo_key] = entry
    if entry is False:
        return fn(*args)
    run, out_tree = entry
    try:
        out = run(*[leaves[i] for i in dynamic])
    except Exception:  # noqa: BLE001  (a program this JAX cannot run, or an error of the inputs:
        _memo[memo_key] = False  # fn itself from now on, which raises such an error with its own message)
        return fn(*args)
    return out if out_tree is None else jax.tree_util.tree_unflatten(out_tree, out)


def _memo_key(fn, leaves, treedef):
    """``(indices of the array leaves, key of`` :data:`_memo` ``)``; the key ``None`` for an
    unhashable static value."""
    dynamic = [i for i, x in enumerate(leaves) if _is_array(x)]
    static = tuple(None if _is_array(x) else x for x in leaves)
    shapes = tuple((tuple(leaves[i].shape), str(leaves[i].dtype), bool(getattr(leaves[i], "weak_type", False)))
                   for i in dynamic)
    key = (fn, treedef, static, shapes, jax._src.config.trace_context())
    try:
        hash(key)
    except TypeError:
        return dynamic, None
    return dynamic, key


def _concrete(fn, args):
    """``(leaves, treedef, dynamic, memo key)`` of a call of ``fn`` on ``args`` that can have a
    program of its own (outside any trace, no traced leaf, hashable static values); ``None``
    otherwise."""
    if not _outside_traces():
        return None
    leaves, treedef = jax.tree_util.tree_flatten(args)
    if any(isinstance(x, jax.core.Tracer) for x in leaves):
        return None
    dynamic, memo_key = _memo_key(fn, leaves, treedef)
    return None if memo_key is None else (leaves, treedef, dynamic, memo_key)


def compile_ahead(fn, *args) -> bool:
    """Start tracing and compiling, in a background thread, the program that ``call(fn, *args,
    store=False)`` runs (the values of ``args`` do not matter, their shapes and static parts do),
    so that a later call finds it compiled: the compilation overlaps the caller's other work (XLA
    and the program's execution release the interpreter, so on a second core it costs no wall
    time). A :func:`call` with that key waits for the thread. Returns whether a thread was started
    (not where the program is known already, or where :func:`call` would not compile a program of
    its own: no options, a trace under way). An error in the thread is dropped: the call then
    compiles (and raises) as usual. The thread is not a daemon: an interpreter that ends while it
    compiles waits for it (a daemon thread stopped inside XLA aborted the process)."""
    if compiler_options() is None:
        return False
    split = _concrete(fn, args)
    if split is None:
        return False
    leaves, treedef, dynamic, memo_key = split
    entry = _in_process(fn, leaves, treedef, dynamic)
    values = [leaves[i] for i in dynamic]

    def work():
        try:
            entry[0].lower(*values).compile()  # JAX keeps it: the jitted function's call reuses it
        except Exception:  # noqa: BLE001  (the call compiles again and reports the error itself)
            pass

    with _ahead_lock:  # both entries or neither, as call sees them
        if memo_key in _memo or memo_key in _ahead:
            return False
        _memo[memo_key] = entry
        _ahead[memo_key] = thread = threading.Thread(target=work, name="jaxroll-compile-ahead")
        thread.start()
    return True


def compiled(fn, args, static=None):
    """``fn(*args, **static)`` (``static``: keyword arguments, all static) compiled ahead of time
    from its stored lowered program (:func:`call`'s folder: loaded where a process stored it
    before, lowered and stored otherwise; JAX's cache then serves the compiled program): a
    function ``run(*new_args)`` of arguments shaped like ``args`` (the same static parts and
    shapes), or ``None`` where the program cannot be stored (the cache off, a trace under way, a
    static value without an exact text, an export JAX refuses, e.g. of a program with a host
    callback) or the loaded one does not compile: the caller then compiles ``fn`` itself. A loaded
    program that fails to run leaves ``fn`` to run itself from then on (as :func:`call`). For
    programs that a caller compiles ahead of their run (:func:`jaxroll.buckets.compiled`)."""
    split = None if programs_directory() is None else _concrete(fn, args)
    if split is None:
        return None
    leaves, treedef, dynamic, memo_key = split
    entry = _lowered(fn, leaves, treedef, dynamic, memo_key[3], static or {})
    if not entry:
        return None
    jitted, out_tree = entry
    try:
        program = [jitted.lower(*[leaves[i] for i in dynamic]).compile()]
    except Exception:  # noqa: BLE001  (a stored program this JAX cannot compile: the caller compiles fn)
        return None

    def run(*new_args):
        if program[0] is not None:
            values = jax.tree_util.tree_leaves(new_args)
            try:
                return jax.tree_util.tree_unflatten(out_tree, program[0](*[values[i] for i in dynamic]))
            except Exception:  # noqa: BLE001  (fn itself from now on, which raises its own errors)
                program[0] = None
        return fn(*new_args, **(static or {}))

    return run


def _in_process(fn, leaves, treedef, dynamic):
    """``(run, None)``: ``fn`` at this static configuration as a top-level program of its own,
    compiled with jaxroll's XLA options (:mod:`jaxroll._xla_options`), for a program that is not
    stored; ``False`` where there are no options (then ``fn`` runs as usual)."""
    options = compiler_options()
    if options is None:
        return False
    template = [None if i in dynamic else x for i, x in enumerate(leaves)]

    def run(*values):
        full = list(template)
        for i, v in zip(dynamic, values):
            full[i] = v
        return fn(*jax.tree_util.tree_unflatten(treedef, full))

    return jax.jit(run, compiler_options=options), None


def _outside_traces() -> bool:
    """Whether no JAX transformation is tracing (a call inside a user's ``jit`` with concrete
    inputs runs ``fn`` itself, as part of the user's program) and ``jax.disable_jit`` is off."""
    clean = getattr(jax._src.core, "trace_state_clean", None)
    return bool(clean and clean()) and not jax.config.jax_disable_jit


def _qualname_of(fn) -> str:
    fn = getattr(fn, "__wrapped__", fn)
    return f"{fn.__module__}.{fn.__qualname__}"


def _outside_source(fn) -> str:
    """A hash of the file that defines ``fn`` where that is not part of jaxroll (whose source
    the key holds already); ``""`` otherwise."""
    import sys

    module = sys.modules.get(getattr(getattr(fn, "__wrapped__", fn), "__module__", ""))
    path = Path(getattr(module, "__file__", None) or "")
    if not path.is_file():
        raise _NotPlain(fn)
    if path.resolve().is_relative_to(Path(__file__).resolve().parent):
        return ""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _is_array(x) -> bool:
    """An input of the program (not part of its key): equinox's ``is_array`` (JAX and NumPy
    arrays, NumPy scalars), so that a program stored for an ``equinox.filter_jit`` function takes
    the same inputs as the function's own (a NumPy scalar is an input of both)."""
    import numpy as np

    return isinstance(x, (jax.Array, np.ndarray, np.generic))


#: Prefix of jaxlib's LAPACK kernels (e.g. ``lapack_dtrsm_ffi``, a triangular solve).
_LAPACK = "lapack_"


def _prepare_custom_calls(targets) -> bool:
    """Make the custom-call kernels of a loaded program callable; ``False`` where that cannot be
    done (then the function runs itself). jaxlib's LAPACK kernels take their function pointers
    from SciPy's LAPACK when a program that uses them is *lowered*; a process that only loads
    stored programs lowers none, and calling such a kernel uninitialised crashes the process
    (a segmentation fault: seen with the default sphere point's triangular solve)."""
    if not targets:
        return True
    try:
        from jaxlib import lapack

        lapack._lapack.initialize()
    except Exception:  # noqa: BLE001  (a jaxlib without this entry point: trace the function instead)
        return False
    return all(t.startswith(_LAPACK) for t in targets)


def _lowered(fn, leaves, treedef, dynamic, shapes, static=None):
    """``(run, output structure)`` of ``fn`` at this configuration (``static``: keyword arguments
    of ``fn``, static), loaded or lowered and stored; ``False`` where it cannot be stored (then
    ``fn`` runs as usual)."""
    import dataclasses
    import logging
    import pickle

    directory = programs_directory()
    if directory is None:
        return False
    try:
        key = "|".join((_key_prefix(), _qualname_of(fn), _outside_source(fn), _structure(treedef),
                        _canon(tuple(None if _is_array(x) else x for x in leaves)), repr(shapes),
                        repr(jax._src.config.trace_context()))) + (f"|{_canon(dict(sorted(static.items())))}"
                                                                  if static else "")
    except _NotPlain:
        return False
    path = directory / f"{getattr(fn, '__name__', 'fn')}-{hashlib.sha256(key.encode()).hexdigest()[:32]}.pkl"
    try:
        with open(path, "rb") as fh:
            stored = pickle.load(fh)
        if stored["key"] == key and _prepare_custom_calls(stored["custom_calls"]):
            exported = stored["exported"]
            try:
                os.utime(path)  # used: the last to go when the folder is trimmed
            except OSError:  # a read-only cache folder: loaded all the same
                pass
            return jax.jit(exported.call, compiler_options=compiler_options()), jax.tree_util.tree_structure(
                stored["outputs"])
    except Exception:  # noqa: BLE001  (absent, unreadable or from another version: lower anew)
        pass

    def flat(*values):
        full = list(leaves)
        for i, v in zip(dynamic, values):
            full[i] = v
        out, out_tree = jax.tree_util.tree_flatten(fn(*jax.tree_util.tree_unflatten(treedef, full), **(static or {})))
        structure.append(out_tree)
        return out

    structure: list = []
    avals = [jax.ShapeDtypeStruct(s, d, weak_type=w) for s, d, w in shapes]
    try:
        exported = jax.export.export(jax.jit(flat))(*avals)
        if exported.ordered_effects or exported.unordered_effects or exported.nr_devices != 1:
            return False
        custom_calls = sorted(set(re.findall(r"custom_call @(\w+)", exported.mlir_module())))
        if not all(t.startswith(_LAPACK) for t in custom_calls):  # only kernels this module can prepare
            return False
        outputs = jax.tree_util.tree_unflatten(structure[0], range(structure[0].num_leaves))
        blob = pickle.dumps({"key": key, "exported": dataclasses.replace(exported, _get_vjp=None), "outputs": outputs,
                             "custom_calls": custom_calls})
        directory.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_bytes(blob)
        os.replace(tmp, path)
        _trim(directory, MAX_LOWERED_BYTES)
    except Exception as err:  # noqa: BLE001  (an unexportable program or an unwritable folder: run fn itself)
        logging.getLogger("jaxroll").debug("not storing the lowered program of %s: %s", _qualname_of(fn), err)
        return False
    return jax.jit(exported.call, compiler_options=compiler_options()), structure[0]


def _trim(directory: Path, limit: int) -> None:
    """Remove the least recently used (oldest modification time) stored programs of ``directory``
    until the rest fit in ``limit`` bytes. Another process may remove the same files at the same
    time: a file already gone is skipped."""
    files = []
    for path in directory.glob("*.pkl"):
        try:
            stat = path.stat()
        except OSError:
            continue
        files.append((stat.st_mtime, stat.st_size, path))
    total = sum(size for _, size, _ in files)
    for _, size, path in sorted(files, key=lambda f: f[0]):
        if total <= limit:
            break
        try:
            path.unlink()
        except OSError:
            pass
        total -= size
