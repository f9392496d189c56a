"""Every notebook in notebooks/ runs without a cell error (quick mode) and is committed clean.

The notebooks are executed with nbclient in a ``python3`` kernel whose working directory is
``notebooks/`` and whose environment has ``EAPLAN_NOTEBOOK_QUICK=1`` (each notebook shortens its
runs then; all of them together take well under a minute).
"""

from pathlib import Path

import nbclient
import nbformat
import pytest

pytestmark = pytest.mark.slow

NOTEBOOK_DIR = Path(__file__).resolve().parents[1] / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
QUICK_SWITCH = "EAPLAN_NOTEBOOK_QUICK"
CELL_TIMEOUT = 300  # [s] per cell; generous, a quick run takes seconds


def _ids(path: Path) -> str:
    return path.name


def test_the_notebooks_are_there():
    names = {p.name for p in NOTEBOOKS}
    assert {
        "01_energy_model.ipynb",
        "02_coverage_guidance.ipynb",
        "03_reference_flights.ipynb",
        "04_study.ipynb",
    } <= names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=_ids)
def test_committed_without_outputs_and_with_a_quick_switch(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code, f"{path.name}: no code cells"
    for i, cell in enumerate(nb.cells):
        if cell.cell_type != "code":
            continue
        assert cell.execution_count is None, f"{path.name}: cell {i} has an execution count"
        assert cell.outputs == [], f"{path.name}: cell {i} has outputs"
    assert any(QUICK_SWITCH in c.source for c in code), f"{path.name}: no {QUICK_SWITCH} switch"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=_ids)
def test_notebook_runs_without_errors(path, monkeypatch):
    # The kernel inherits this process's environment when it starts.
    monkeypatch.setenv(QUICK_SWITCH, "1")
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(
        nb,
        kernel_name="python3",
        timeout=CELL_TIMEOUT,
        resources={"metadata": {"path": str(NOTEBOOK_DIR)}},
    )
    try:
        client.execute()
    except nbclient.exceptions.CellExecutionError as e:
        pytest.fail(f"{path.name}: a cell failed:\n{e}")
    errors = [
        (i, out.get("ename"), out.get("evalue"))
        for i, cell in enumerate(nb.cells)
        if cell.cell_type == "code"
        for out in cell.outputs
        if out.output_type == "error"
    ]
    assert errors == [], f"{path.name}: {errors}"
    executed = [c.execution_count for c in nb.cells if c.cell_type == "code"]
    assert all(n is not None for n in executed), f"{path.name}: not every cell ran"
