"""The tolerances: section: its defaults, its errors (one line naming file and key), and the
box it makes around a design."""
import numpy as np
import pytest

from optdesign.cli import main
from optdesign.errors import ProblemError
from optdesign.problem.loader import problem_from_dict
from optdesign.tolerance.parts import box_of, draw_offsets
from optdesign.tolerance.section import ToleranceSection
from tests.tolerance.conftest import paper


def test_defaults_and_per_length_entries():
    problem = problem_from_dict(paper(tolerances={"lengths": {"l3": 0.02, "l1": 0}}))
    section = problem.sections["tolerances"]
    assert section == ToleranceSection(lengths={"l3": 0.02, "l1": 0.0}, source="<dict>")
    assert section.band("fourbar_converter") == {"l0": 0.05, "l1": 0.0, "l2": 0.05,
                                                 "l2_prime": 0.05, "l3": 0.02}
    assert problem_from_dict(paper(tolerances=None)).sections["tolerances"].default == 0.05


@pytest.mark.parametrize("section, message", [
    ({"lengths": {"l9": 0.1}}, "p.yaml: tolerances.lengths.l9 is not a length of "
                               "fourbar_converter"),
    ({"lengths": {"phases": 1}}, "p.yaml: tolerances.lengths.phases is the count"),
    ({"lengths": {"l3": -0.1}}, "p.yaml: tolerances.lengths.l3 must not be negative"),
    ({"lengths": {"l1": 20}}, "p.yaml: tolerances.lengths.l1 must be below the least value "
                              "of design.l1, 20 mm"),
    ({"default": "0.05"}, "p.yaml: tolerances.default must be a number"),
    ({"distribution": "gauss"}, "p.yaml: tolerances.distribution must be one of uniform, "
                                "normal"),
    ({"k": 0}, "p.yaml: tolerances.k must be positive"),
    ({"samples": 0}, "p.yaml: tolerances.samples must be at least 1"),
    ({"sigma": 1}, "p.yaml: tolerances.sigma is not a known key"),
])
def test_bad_values_name_the_file_and_key(section, message, write_problem, capsys):
    with pytest.raises(ProblemError, match="^" + message.replace(".", r"\.")):
        problem_from_dict(paper(tolerances=section), where="p.yaml")
    path = write_problem(paper(tolerances=section))
    assert main(["tolerance", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "tolerances." in err and "p.yaml" in err


def test_the_command_needs_the_section(write_problem, capsys):
    assert main(["tolerance", str(write_problem(paper()))]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "p.yaml: has no tolerances: section; add one" in err


def test_the_box_and_its_parts(paper_problem):
    box = box_of(paper_problem, {"l3": 60.0}, {"l3": 0.1, "l1": 0.02})
    assert box.values["l3"] == 60.0 and list(box.band) == [0, 0.02, 0, 0, 0.1]
    assert list(box.toleranced) == [1, 4]
    offsets = draw_offsets(box, 2000, "normal", k=3.0, seed=4)
    assert np.all(np.abs(offsets) <= box.band)            # cut at ± the tolerance
    assert np.std(offsets[:, 4]) == pytest.approx(0.1 / 3, rel=0.1)
    uniform = draw_offsets(box, 2000, seed=4)
    assert np.abs(uniform[:, 4]).max() > 0.099 and np.all(uniform[:, 0] == 0)
    with pytest.raises(ProblemError, match="tolerance of l1"):
        box_of(paper_problem, None, {"l1": 25.0})
