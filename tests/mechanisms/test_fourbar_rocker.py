"""The four-bar's rockers i >= 2 are one SX function called per rocker: the functions made from
the model are those of the same arithmetic written out rocker by rocker, to the serialised text
(so the same values, digests and compiled libraries)."""
import math

import casadi as ca
import pytest

from optdesign.mechanisms import get_mechanism
from optdesign.mechanisms.fourbar_converter import BRANCH_SIGN
from optdesign.mechanisms.geometry import (angle_of, circle_intersection, direction, rotated,
                                           unit)


def _written_out(phi, p, count, options, coupler_angle=True):
    """Sharkov & Kalinin 2022, eqs. (1)-(4), each rocker's circle intersection written out."""
    l0, l1, l2, l2p, l3 = (p[k] for k in ("l0", "l1", "l2", "l2_prime", "l3"))
    sign = BRANCH_SIGN[options["branch"]]
    pin_radius = l2 - l2p if options["pin_layout"] == "collinear" else l2p
    tau = 2 * math.pi / count
    a = l1 * unit(phi)
    o1 = ca.vertcat(l0, 0)
    b1, cos_mu1 = circle_intersection(a, l2, o1, l3, sign)
    phi2 = angle_of(b1 - a) if coupler_angle else None
    u2 = None if coupler_angle else direction(b1 - a)
    theta, cos_mu = [angle_of(b1 - o1)], [cos_mu1]
    joints = {"O": ca.vertcat(0, 0), "A": a, "O1": o1, "B1": b1}
    links = [("O", "A"), ("A", "B1"), ("O1", "B1")]
    for i in range(2, count + 1):
        angle = (i - 1) * tau
        o_i = l0 * unit(angle)
        towards = unit(angle + phi2) if coupler_angle else rotated(u2, angle)
        c_i = a + pin_radius * towards
        b_i, cos_mu_i = circle_intersection(o_i, l3, c_i, l2p, -sign)
        theta.append(angle_of(b_i - o_i))
        cos_mu.append(cos_mu_i)
        joints |= {f"O{i}": o_i, f"C{i}": c_i, f"B{i}": b_i}
        links += [("A", f"C{i}"), (f"C{i}", f"B{i}"), (f"O{i}", f"B{i}")]
    return {"theta": theta, "cos_mu": cos_mu, "joints": joints, "links": links}


def _texts(model, count, options) -> list[str]:
    joints = model.joints(count, options)[0]
    return [f.serialize() for f in (model.kinematics(count, options),
                                    model.speeds(count, options), joints,
                                    *model._chains(count, options))]


def _cleared(model) -> None:
    for built in (model.symbolic, model.kinematics, model.speeds, model.joints,
                  model._chains):
        built.cache_clear()


@pytest.mark.parametrize("count", [2, 3, 6, 13])
@pytest.mark.parametrize("branch, pin_layout", [("left", "collinear"), ("right", "text")])
def test_rockers_as_one_function_are_the_written_out_arithmetic(monkeypatch, count, branch,
                                                               pin_layout):
    model = get_mechanism("fourbar_converter")
    options = (("branch", branch), ("pin_layout", pin_layout))
    _cleared(model)
    ours = _texts(model, count, options)
    monkeypatch.setattr(type(model), "chain_expressions",
                        lambda self, phi, p, n, opts, coupler_angle=True:
                        _written_out(phi, p, n, opts, coupler_angle))
    _cleared(model)
    try:
        written = _texts(model, count, options)
    finally:
        _cleared(model)     # the written-out model's functions are not left in the caches
    assert len(ours) == len(written) == 3 + count
    assert ours == written
