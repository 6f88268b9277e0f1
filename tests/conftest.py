"""Test configuration: float64 everywhere, strict dtype promotion, and a suite that compiles less.

The suite is bound by XLA compilation, not by running programs (a slice call compiles in seconds
and then runs in milliseconds). Settings made here before jax starts cut that time for the
tests and for every subprocess they start (README blocks, CLI commands, notebook kernels), which
inherit the environment:

- XLA:CPU flags that compile faster (``tests/_xla.py``): the element-wise emitters instead of the
  fusion emitters, and no LLVM optimisation passes, for the test processes and the interpreters
  they start (which inherit the environment); the run-bound interpreters (the docs' ``jaxroll
  fit`` commands, notebook 03's fits) keep LLVM's passes, and so do the programs of tests marked
  ``run_bound`` (:func:`_run_bound`). ``JAXROLL_TEST_XLA_DEFAULT=1``: XLA's defaults everywhere,
  for comparison.
- jaxroll's stored lowered programs off (``JAXROLL_COMPILATION_CACHE=0``; JAX's own cache
  below stays on), as their first export costs more than a jit; tests/test_errors.py checks them.
- One persistent compilation cache per test session (a temporary folder, removed at the end):
  a program compiled once is loaded, not recompiled, when another test module (after
  ``jax.clear_caches`` below), a rebuilt ``jax.jit(lambda ...)`` or a subprocess lowers the same
  program again. Programs with host callbacks (``jax.debug.callback``) are not stored. Under
  pytest-xdist (``-n``, on by default in pyproject.toml) the controller creates and removes the
  folder, and every worker, with the subprocesses it starts, keeps its own subfolder: jax writes
  a cache file in place, and a process must not load a program that another is still writing.

Set ``JAXROLL_TEST_CPU_LOG=PREFIX`` to write every test's CPU time (user + system, of the test
process and of the subprocesses it waited for; the steady figure on a shared machine) and wall time
to ``PREFIX.<worker>`` (``benchmarks/suite_cost.py`` runs the suite so and sums it per file).
Set ``JAXROLL_TEST_PLAIN_XLA=1`` to run with jax's defaults (no flag, no cache), for comparison,
and ``JAXROLL_TEST_CLEAR_EVERY_MODULE=1`` to drop the compiled programs after every module (see
:func:`_release_compiled_programs`). The run ends with a line that counts the programs compiled
and those loaded from the persistent cache, summed over the xdist workers.
"""

import gc
import os
import shutil
import tempfile
import time

import _xla  # tests/_xla.py: no jax import

if not os.environ.get("JAXROLL_TEST_PLAIN_XLA"):
    os.environ["XLA_FLAGS"] = _xla.light_xla_flags(os.environ.get("XLA_FLAGS"))  # see the module docstring
    # XLA:CPU logs three lines per program it loads from a persistent cache on some x86 CPUs
    # ("Loading XLA:CPU AOT result ... prefer-no-gather", an upstream XLA message): keep them out
    # of the subprocesses' stderr that CLI tests read
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "3")
    # jaxroll's stored lowered programs off (JAX's cache, set below, stays on: a folder set for
    # JAX wins): they spare a later process the tracing, but a program's first export and reload
    # cost more CPU than jit alone (benchmarks/LOG.md), and the tests' programs are rarely met
    # again in another process. tests/test_errors.py checks the stored programs themselves.
    os.environ.setdefault("JAXROLL_COMPILATION_CACHE", "0")
    if os.environ.get("PYTEST_XDIST_WORKER") and os.environ.get("JAXROLL_TEST_CACHE_ROOT"):
        # a pytest-xdist worker: its own folder inside the controller's, so that no process reads
        # a program that another one is still writing (jax writes cache files in place). One
        # folder for all would share programs (a key holds the folder's path, so subfolders never
        # do), but jax's lock for it comes with its size cap, whose check reads every entry's
        # access-time file at every write: the suite took 10.7 instead of ~9 min (benchmarks/LOG.md)
        os.environ["JAX_COMPILATION_CACHE_DIR"] = os.path.join(
            os.environ["JAXROLL_TEST_CACHE_ROOT"], os.environ["PYTEST_XDIST_WORKER"])
    elif "JAX_COMPILATION_CACHE_DIR" not in os.environ:
        _CACHE_DIR = tempfile.mkdtemp(prefix="jaxroll-tests-xla-")  # the controller's: removed at the end
        os.environ["JAXROLL_TEST_CACHE_ROOT"] = os.environ["JAX_COMPILATION_CACHE_DIR"] = _CACHE_DIR
        os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0"
        os.environ["JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES"] = "-1"

import jax  # noqa: E402  (after the environment above)
import pytest  # noqa: E402

import jaxroll  # noqa: E402, F401  (enables float64)

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")


# What the session compiled and what it loaded from the persistent cache (this process only;
# subprocesses count for themselves), printed at the end of the run
_COMPILATION = {"compiled": 0, "compile_s": 0.0, "lookups": 0, "hits": 0, "saved_s": 0.0}
#: pytest-xdist workers whose counts were added to :data:`_COMPILATION` (controller only)
_WORKERS = []


def _count_event(event, **kw):
    if event == "/jax/compilation_cache/compile_requests_use_cache":
        _COMPILATION["lookups"] += 1
    elif event == "/jax/compilation_cache/cache_hits":
        _COMPILATION["hits"] += 1


def _count_duration(event, duration, **kw):
    if event == "/jax/core/compile/backend_compile_duration":
        _COMPILATION["compiled"] += 1
        _COMPILATION["compile_s"] += duration
    elif event == "/jax/compilation_cache/compile_time_saved_sec":
        _COMPILATION["saved_s"] += duration


jax.monitoring.register_event_listener(_count_event)
jax.monitoring.register_event_duration_secs_listener(_count_duration)


def pytest_terminal_summary(terminalreporter):
    c = _COMPILATION
    terminalreporter.write_line(
        f"XLA: {c['compiled']} programs compiled in {c['compile_s']:.0f} s; persistent cache: {c['hits']} of "
        f"{c['lookups']} lookups loaded (~{max(c['saved_s'], 0.0):.0f} s of compilation saved; programs with host "
        f"callbacks are never stored; {len(_WORKERS) or 1} test process(es))")


def pytest_sessionfinish(session, exitstatus):
    log = os.environ.get("JAXROLL_TEST_CPU_LOG")
    if log:  # the whole process (collection, imports and fixtures outside the tests included)
        # a pytest-xdist controller counts only itself: its workers are its children, and each
        # logs its own total (counting them here too doubled the sum in benchmarks/suite_cost.py)
        t = os.times()
        cpu = t.user + t.system if _WORKERS else _cpu_seconds()
        with open(f"{log}.{os.environ.get('PYTEST_XDIST_WORKER', 'main')}", "a") as out:
            out.write(f"<process total>\t{cpu:.2f}\t{time.perf_counter():.2f}\t{os.getloadavg()[0]:.1f}\n")
    if hasattr(session.config, "workeroutput"):  # a pytest-xdist worker: report to the controller
        session.config.workeroutput["jaxroll_compilation"] = dict(_COMPILATION)
    cache = globals().get("_CACHE_DIR")
    if cache:
        shutil.rmtree(cache, ignore_errors=True)


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    """pytest-xdist controller: add a finished worker's counts to the summary line."""
    counts = getattr(node, "workeroutput", {}).get("jaxroll_compilation", {})
    if counts:
        _WORKERS.append(node.gateway.id)
    for key, value in counts.items():
        _COMPILATION[key] += value


def _cpu_seconds() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """With ``JAXROLL_TEST_CPU_LOG`` set: log the test's CPU and wall seconds (setup, call and
    teardown, module fixtures included in the test that runs them)."""
    log = os.environ.get("JAXROLL_TEST_CPU_LOG")
    if not log:
        yield
        return
    cpu0, wall0 = _cpu_seconds(), time.perf_counter()
    yield
    cpu, wall = _cpu_seconds() - cpu0, time.perf_counter() - wall0
    with open(f"{log}.{os.environ.get('PYTEST_XDIST_WORKER', 'main')}", "a") as out:
        out.write(f"{item.nodeid}\t{cpu:.2f}\t{wall:.2f}\t{os.getloadavg()[0]:.1f}\n")


#: XLA options added to every program compiled while a ``run_bound`` test runs (see :func:`_run_bound`)
_COMPILE_OVERRIDES: dict = {}


def _with_overrides(get_compile_options):
    def wrapped(*args, env_options_overrides=None, **kwargs):
        if _COMPILE_OVERRIDES:
            env_options_overrides = {**_COMPILE_OVERRIDES, **(env_options_overrides or {})}
        return get_compile_options(*args, env_options_overrides=env_options_overrides, **kwargs)
    return wrapped


try:  # jax's internal hook for per-program XLA options (``jax.jit(..., compiler_options=)`` uses it)
    from jax._src import compiler as _compiler

    _compiler.get_compile_options = _with_overrides(_compiler.get_compile_options)
except (ImportError, AttributeError):  # another jax: run-bound tests then compile as the others
    pass


@pytest.fixture(autouse=True)
def _run_bound(request):
    """Tests marked ``run_bound`` (programs that run long: fits, many solves) compile with LLVM's
    optimisation passes (XLA's default level, 3), the others without (``tests/_xla.py``). The
    process's compiled programs are dropped first, so that the test does not reuse one that an
    earlier test compiled without them (the persistent cache keys the level)."""
    if request.node.get_closest_marker("run_bound") is None or os.environ.get(_xla.DEFAULT_ENV):
        yield
        return
    jax.clear_caches()
    _COMPILE_OVERRIDES["xla_backend_optimization_level"] = 3
    try:
        yield
    finally:
        _COMPILE_OVERRIDES.clear()


#: Memory mappings of this process above which the compiled programs are dropped after a test
#: module: half the usual kernel limit (``vm.max_map_count``, 65530), far above what one module adds
MAX_MAPPINGS = 32768


def _mappings() -> int | None:
    """Number of memory mappings of this process (``None`` where ``/proc`` is unavailable)."""
    try:
        with open(f"/proc/{os.getpid()}/maps") as fh:
            return sum(1 for _ in fh)
    except OSError:
        return None


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    """Drop jax's compiled programs after a test module once the process holds many of them.

    Every compiled XLA:CPU program keeps a few memory mappings for its code; a process that runs
    the whole suite accumulated them until the kernel's limit (``vm.max_map_count``, 65530 here)
    and XLA aborted inside a compile ("Fatal Python error: Aborted", no message) near the end of
    the suite. Clearing after every module cost the next module its tracing and every small
    program again (eager operations, programs with host callbacks, which the persistent cache
    does not keep), so the programs are dropped only above :data:`MAX_MAPPINGS` (always where the
    count is unknown). A program that a later module needs again comes back from the session's
    persistent compilation cache (above) instead of being compiled again."""
    yield
    before = _mappings()
    if before is None or before > MAX_MAPPINGS or os.environ.get("JAXROLL_TEST_CLEAR_EVERY_MODULE"):
        jax.clear_caches()
        gc.collect()
    if os.environ.get("JAXROLL_TEST_MAPS"):
        with open(os.environ["JAXROLL_TEST_MAPS"], "a") as out:
            out.write(f"{before} {_mappings()}\n")


#: Modules that start interpreters or notebook kernels: few tests, each long. They come first, so
#: that pytest-xdist (``--dist loadfile --no-loadscope-reorder``, pyproject.toml) hands them out
#: while the other workers take the many short modules, instead of leaving one worker alone with
#: them at the end (the other modules keep their collection order).
RUN_FIRST = ("test_notebooks.py", "test_docs.py", "test_sweep.py", "test_errors.py")


def pytest_collection_modifyitems(config, items):
    rank = {name: k for k, name in enumerate(RUN_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(RUN_FIRST)))  # stable: modules stay whole
