"""Problems of the tolerance tests: the paper's design, every length fixed."""
import pytest
import yaml

from optdesign.problem.loader import problem_from_dict
from tests.conftest import ROOT


def paper(**changes) -> dict:
    """sharkov2022.yaml (the paper's design, n = 6) as a mapping, with ``changes``."""
    data = yaml.safe_load((ROOT / "problems" / "sharkov2022.yaml").read_text())
    data["regulation"] = {"eccentricity": [1.0]}
    data.update(changes)
    return data


@pytest.fixture(scope="package")
def paper_problem():
    return problem_from_dict(paper(tolerances={"default": 0.05}), where="paper.yaml")
