"""Execute every notebook of notebooks/ at reduced resolution (``JAXROLL_NOTEBOOK_QUICK=1``) in a
temporary folder and write the executed copies, with their outputs, to docs/notebooks/ for the
documentation site (the sources in notebooks/ stay stripped).

    python docs/execute_notebooks.py            # all notebooks
    python docs/execute_notebooks.py 01 05      # those whose names start so

Each copy records its run time, the jaxroll version and the machine in its metadata
(``jaxroll_run``); tests/test_docs_site.py checks that every copy's code cells equal the source's,
so a changed notebook cannot keep a stale rendering.
"""

import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import nbclient
import nbformat

ROOT = Path(__file__).resolve().parent.parent
SOURCES = ROOT / "notebooks"
TARGET = ROOT / "docs" / "notebooks"


def execute(path: Path, target: Path = TARGET) -> float:
    """Run ``path`` in a temporary folder and write the executed notebook to ``target``;
    returns the wall time [s]."""
    nb = nbformat.read(path, as_version=4)
    os.environ["JAXROLL_NOTEBOOK_QUICK"] = "1"
    os.environ.pop("MPLBACKEND", None)  # the kernel's inline backend, as for a user
    # XLA's C++ log lines (e.g. "Loading XLA:CPU AOT result" for programs from the persistent
    # cache) go to the kernel's stderr, which the kernel captures into the outputs
    os.environ["TF_CPP_MIN_LOG_LEVEL"] = "3"
    with tempfile.TemporaryDirectory() as work:
        t0 = time.perf_counter()
        nbclient.NotebookClient(nb, timeout=900, kernel_name="python3",
                                resources={"metadata": {"path": work}}).execute()
        seconds = time.perf_counter() - t0
    import jaxroll

    nb.metadata["jaxroll_run"] = {
        "quick": True, "seconds": round(seconds, 1), "jaxroll": jaxroll.__version__,
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}",
        "date": time.strftime("%Y-%m-%d"),
    }
    target.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, target / path.name)
    return seconds


def main(prefixes):
    paths = sorted(SOURCES.glob("*.ipynb"))
    if prefixes:
        paths = [p for p in paths if any(p.name.startswith(x) for x in prefixes)]
    for path in paths:
        print(f"{path.name}: {execute(path):.1f} s", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
