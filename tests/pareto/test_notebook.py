"""notebooks/design_space.ipynb runs top to bottom on the small front (no network needed)."""
import sys

import pytest

from tests.conftest import ROOT

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")


def test_design_space_notebook_executes(small_front, small_path, monkeypatch):
    from jupyter_client.kernelspec import KernelSpecManager, NoSuchKernel
    try:
        KernelSpecManager().get_kernel_spec("python3")
    except NoSuchKernel:                 # a fresh venv without a kernelspec: install one
        from ipykernel.kernelspec import install
        install(prefix=sys.prefix)
    monkeypatch.setenv("OPTDESIGN_FRONT", str(small_front[1] / "pareto.csv"))
    monkeypatch.setenv("OPTDESIGN_PROBLEM", str(small_path))
    monkeypatch.setenv("PYTHONPATH", str(ROOT))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(ROOT / "notebooks" / "design_space.ipynb", as_version=4)
    client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=120,
                                     resources={"metadata": {"path": str(ROOT / "notebooks")}})
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs)
    assert "non-dominated designs, hypervolume" in text and "feasible: True" in text
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 4             # fronts, lengths, speeds, mechanism
