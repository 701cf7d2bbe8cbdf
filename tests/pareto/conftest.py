"""A small front problem (two free lengths, n = 4, a few points) swept once for the tests."""
import pytest
import yaml

#: l1 and l3 free, the rest at the pareto_fourbar knee's values: a real, short trade-off
#: (δ 0.21 -> 0.43 as the ratio goes 0.833 -> 0.848), ~1 s of IPOPT per point.
SMALL = {
    "name": "small_front",
    "mechanism": "fourbar_converter",
    "input_speed": 97.0,
    "stroke": "reverse",
    "design": {"l0": 360, "l1": {"lower": 15, "upper": 60, "initial": 22}, "l2": 360,
               "l2_prime": 300, "l3": {"lower": 30, "upper": 90, "initial": 30},
               "phases": 4},
    "constraints": {"min_transmission_angle_deg": 30, "min_pin_radius": 60},
    "solver": {"starts": 2},
    # the uniform pass alone: these tests count its points (test_refinement.py refines)
    "pareto": {"points": 4, "refine": {"enabled": False}},
}


def small(**pareto) -> dict:
    data = yaml.safe_load(yaml.safe_dump(SMALL))
    data["pareto"].update(pareto)
    return data


@pytest.fixture(scope="session")
def small_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("pareto_problem") / "small_front.yaml"
    path.write_text(yaml.safe_dump(SMALL))
    return path


@pytest.fixture(scope="session")
def small_front(small_path, tmp_path_factory):
    """(result, out folder) of one in-process sweep of the small problem."""
    from optdesign.fronts import sweep
    from optdesign.problem.loader import load_problem
    out = tmp_path_factory.mktemp("pareto_out")
    return sweep(load_problem(small_path), out, workers=1, progress=False), out
