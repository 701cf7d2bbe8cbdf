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
    monkeypatch.setenv("PYTHONPATH", str(ROOT))
    nb = nbformat.read(ROOT / "notebooks" / "design_space.ipynb", as_version=4)
    inputs = next(c for c in nb.cells if c.cell_type == "code")
    assert "PROBLEM =" in inputs.source and "FRONT =" in inputs.source
    inputs.source = f"PROBLEM = {str(small_path)!r}\nFRONT = {str(small_front[1])!r}"
    client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=120,
                                     resources={"metadata": {"path": str(ROOT / "notebooks")}})
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs)
    assert "non-dominated designs, hypervolume" in text and "feasible: True" in text
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) == 4             # fronts, lengths, speeds, mechanism: each once
    tables = [o for o in outputs if "text/html" in o.get("data", {})]
    assert any("non-dominated designs" in o["data"]["text/html"] for o in tables)
    source = "".join(c.source for c in nb.cells if c.cell_type == "code")
    imports = {line.split()[1] for line in source.splitlines()
               if line.startswith(("from optdesign", "import optdesign"))}
    assert imports == {"optdesign"}     # the public API only
