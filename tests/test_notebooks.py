"""Every notebook in notebooks/ executes top to bottom in a temporary folder (in the default suite
at reduced resolution, JAXROLL_NOTEBOOK_QUICK=1; as a user runs it, at full resolution, under
``-m slow``), with the kernel's own (inline) matplotlib
backend, and every cell that draws a figure shows it; the source notebooks stay unexecuted."""

import os
import re
import shutil
from pathlib import Path

import pytest
from _cases import light_xla_flags

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

NOTEBOOKS = sorted((Path(__file__).parent.parent / "notebooks").glob("*.ipynb"))
#: Notebooks whose quick run is bound by running programs, not by compiling them (CPU seconds of
#: the quick run with jax's default flags -> with XLA's light flags): 03's fits, 42.6 -> 63.9 s.
#: They keep the default flags; the others compile faster (01: 39.1 -> 31.5 s, 04: 33.9 -> 25.0 s).
RUN_BOUND = ("03_material_identification",)


def test_notebooks_are_stripped():
    for path in NOTEBOOKS:
        nb = nbformat.read(path, as_version=4)
        for cell in nb.cells:
            if cell.cell_type == "code":
                assert not cell.outputs and cell.execution_count is None, f"{path.name}: outputs not stripped"


@pytest.mark.parametrize("quick", [True, pytest.param(False, marks=pytest.mark.slow)], ids=["quick", "full"])
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_executes(path, quick, tmp_path, monkeypatch):
    work = tmp_path / path.name
    shutil.copy(path, work)
    nb = nbformat.read(work, as_version=4)
    if quick:
        monkeypatch.setenv("JAXROLL_NOTEBOOK_QUICK", "1")
        if path.stem not in RUN_BOUND:  # a few points per program: compile-bound (tests/_cases.py)
            monkeypatch.setenv("XLA_FLAGS", light_xla_flags(os.environ.get("XLA_FLAGS")))
    else:
        monkeypatch.delenv("JAXROLL_NOTEBOOK_QUICK", raising=False)
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
