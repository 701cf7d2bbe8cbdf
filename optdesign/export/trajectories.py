"""Every joint's path and every output member's motion over one crank turn, as a table.

At constant input speed ω1 the output members' angular speed and acceleration are
ω_k = ω1·dθ_k/dφ and ε_k = ω1²·d²θ_k/dφ² (the mechanism's exact derivatives); the output's
speed is the envelope of the driving speeds (Sharkov & Kalinin 2022, eqs. 5-8).
"""
from __future__ import annotations

import numpy as np

from optdesign.envelope.sampled import output_envelope
from optdesign.figures.design import linkage


def trajectories(design, stroke: str, input_speed: float, eccentricity: float = 1.0,
                 samples: int = 360):
    """A DataFrame, one row per crank angle: ``phi_deg``, each joint's ``J_x_mm``/``J_y_mm``,
    each member's ``theta_k_rad``, ``omega_k_rad_s``, ``epsilon_k_rad_s2``, and the
    output's ``omega_out_rad_s``."""
    import pandas as pd

    drawn = linkage(design, eccentricity, samples)
    phi = np.linspace(0.0, 2 * np.pi, samples, endpoint=False)
    kin = design.sample(phi, eccentricity)
    out = {"phi_deg": np.degrees(phi)}
    for joint in drawn.names:
        path = drawn.path(joint)
        out[f"{joint}_x_mm"], out[f"{joint}_y_mm"] = path[:, 0], path[:, 1]
    for k in range(kin["theta"].shape[0]):
        out[f"theta_{k + 1}_rad"] = kin["theta"][k]
        out[f"omega_{k + 1}_rad_s"] = kin["dtheta"][k] * input_speed
        out[f"epsilon_{k + 1}_rad_s2"] = kin["ddtheta"][k] * input_speed ** 2
    out["omega_out_rad_s"] = output_envelope(kin["dtheta"], stroke) * input_speed
    return pd.DataFrame(out)
