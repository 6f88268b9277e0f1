"""Every notebook in notebooks/ executes top to bottom in a temporary folder, with the kernel's own
(inline) matplotlib backend, and every cell that draws a figure shows it; the source notebooks
stay unexecuted.

Each notebook runs at reduced resolution (``JAXROLL_NOTEBOOK_QUICK=1``) and, as a user runs it, at
full resolution. A notebook kernel is a fresh interpreter that compiles every program it uses
again (25-48 s of CPU each at reduced resolution), so the default suite runs the quickstart
(reduced) and the rest under ``-m slow``; what the other notebooks call runs in the default
suite in-process (:data:`COVERED_BY`).
"""

import os
import re
import shutil
from pathlib import Path

import pytest
from _cases import default_xla_flags, light_xla_flags

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

NOTEBOOKS = sorted((Path(__file__).parent.parent / "notebooks").glob("*.ipynb"))
#: Notebooks whose quick run is bound by running programs, not by compiling them (CPU seconds of
#: the quick run with jax's default flags -> with LLVM's passes off): 03's fits, 42.6 -> 63.9 s.
#: They keep LLVM's passes (tests/_xla.py); the others compile faster (01: 39.1 -> 31.5 s, 04:
#: 33.9 -> 25.0 s).
RUN_BOUND = ("03_material_identification",)
#: The notebook that runs at reduced resolution in the default suite: the first a user opens.
DEFAULT = "01_quickstart"
#: For the notebooks whose reduced run is slow: the default-suite tests that call the same
#: library paths in-process (their plots: tests/test_cli.py's material and map commands,
#: tests/test_reproduce.py, tests/test_labelled.py).
COVERED_BY = {
    "02_gradients_and_design": "test_api.py (jit / vmap / grad of the front door), test_direct.py (gradients)",
    "03_material_identification": "test_fit.py (direct-method and joint DMA fits), test_docs.py (README fit)",
    "04_method_comparison": "test_reproduce.py (reproduce.run, its tables and figures)",
    "05_dma_to_rolling": "test_docs.py (README block 1: DMA sweeps to a full-model map), test_dma.py, test_cli.py",
    "06_conveyor_idlers": "test_conveyor.py (conveyor_map and its derivatives), test_docs.py (README block 2)",
}
assert set(COVERED_BY) | {DEFAULT} == {p.stem for p in NOTEBOOKS}, "a new notebook: run it by default or name its cover"


def _cases():
    for path in NOTEBOOKS:
        quick = [] if path.stem == DEFAULT else [pytest.mark.slow]
        yield pytest.param(path, True, marks=quick, id=f"{path.stem}-quick")
        yield pytest.param(path, False, marks=pytest.mark.slow, id=f"{path.stem}-full")


def test_notebooks_are_stripped():
    for path in NOTEBOOKS:
        nb = nbformat.read(path, as_version=4)
        for cell in nb.cells:
            if cell.cell_type == "code":
                assert not cell.outputs and cell.execution_count is None, f"{path.name}: outputs not stripped"


@pytest.mark.parametrize(("path", "quick"), list(_cases()))
def test_notebook_executes(path, quick, tmp_path, monkeypatch):
    work = tmp_path / path.name
    shutil.copy(path, work)
    nb = nbformat.read(work, as_version=4)
    if quick:
        monkeypatch.setenv("JAXROLL_NOTEBOOK_QUICK", "1")
    else:
        monkeypatch.delenv("JAXROLL_NOTEBOOK_QUICK", raising=False)
    # a few points per program: compile-bound; the fits run-bound (tests/_cases.py)
    light = quick and path.stem not in RUN_BOUND
    monkeypatch.setenv("XLA_FLAGS", (light_xla_flags if light else default_xla_flags)(os.environ.get("XLA_FLAGS")))
    # the notebooks run in a temporary folder and read their data through jr.datasets
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel picks its inline backend, as for a user
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors
    # a cell that draws (jaxroll.apps.plot, plt.subplots / plt.figure) must show at least one image
    draws = re.compile(r"\bplot\.plot_|plt\.(subplots|figure)\(")
    for k, cell in enumerate(c for c in nb.cells if c.cell_type == "code"):
        if draws.search(cell.source):
            images = [o for o in cell.outputs if "image/png" in o.get("data", {})]
            assert images, f"{path.name}, code cell {k}: draws a figure but shows no image"
