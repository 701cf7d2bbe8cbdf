"""A tiny atlas (2 phase counts × 2 transmission-angle rules, the disc problem's box and pin
radius relative to its 20 mm crank) and its local run, once per session."""
import pytest
import yaml

from tests.conftest import run_main

TINY = {
    "name": "tiny",
    "mechanism": "fourbar_converter",
    "design": {"l0": {"lower": 5, "upper": 20}, "l2": {"lower": 5, "upper": 20},
               "l2_prime": {"lower": 1.5, "upper": 15}, "l3": {"lower": 1, "upper": 7.5}},
    "axes": {"phases": [4, 6], "min_transmission_angle_deg": [40, 45]},
    "fixed": {"min_pin_radius": 6.25, "min_ratio": 0.344},
    "solver": {"starts": 1, "screen": 64, "workers": 1},
}


@pytest.fixture(scope="session")
def tiny_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("atlas_file") / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY, sort_keys=False))
    return path


@pytest.fixture(scope="session")
def tiny_atlas(tiny_path, tmp_path_factory):
    """(output folder, atlas.csv as a frame) of ``optdesign atlas tiny.yaml --workers 1``."""
    import pandas as pd

    out = tmp_path_factory.mktemp("tiny_atlas")
    code, stdout = run_main(["atlas", tiny_path, "--out", out, "--workers", "1"])
    assert code == 0, stdout
    return out, pd.read_csv(out / "atlas.csv")
