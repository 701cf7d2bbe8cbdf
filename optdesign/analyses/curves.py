"""Position, velocity and acceleration analogues over a turn, for any registered mechanism.

The analogue of a speed is the speed per unit crank speed, dθ/dφ (Vergov's Aω7, eq. 8), that of
an acceleration d²θ/dφ² (both from the mechanism's ``casadi.Function``, by algorithmic
differentiation). Besides every output member θ_k, the freewheels' output of the chosen stroke:
Φ' = max(0, max_k s·dθ_k/dφ) (docs/formulation.md), Φ'' = s·d²θ_k/dφ² of the member driving
at that angle (0 while every freewheel overruns) and Φ = ∫ Φ' dφ from φ = 0. For the pulse
reducer Φ is the paper's position function, eqs. (1)-(2).

The data are computed here; :func:`plot_curves` draws them and imports matplotlib itself.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optdesign.envelope.sampled import STROKE_SIGNS
from optdesign.figures.design import pyplot


@dataclass(frozen=True)
class Curves:
    """Analogues over one turn; angles in rad, ``theta`` etc. members × samples."""

    mechanism: str
    member: str                 # what one output member is called (the count variable)
    stroke: str
    eccentricity: float
    phi: np.ndarray
    theta: np.ndarray
    dtheta: np.ndarray
    ddtheta: np.ndarray
    output_position: np.ndarray      # Φ, rad, Φ(0) = 0
    output_speed: np.ndarray         # Φ' = ω_out/ω1
    output_acceleration: np.ndarray  # Φ''


def member_curves(design, stroke: str, eccentricity: float = 1.0,
                  n_samples: int = 1441) -> Curves:
    """Sample a design over [0, 2π] (plus its breakpoints, approached from both sides).

    Φ is the trapezoid integral of Φ' on the samples: relative error O(h²), about 1e-6 at the
    default 1441 samples, which a figure does not show.
    """
    phi = np.linspace(0.0, 2 * np.pi, n_samples)
    breaks = [b for b in design.breakpoints(eccentricity) if 0 < b < 2 * np.pi]
    phi = np.sort(np.concatenate([phi, [b - 1e-9 for b in breaks], [b + 1e-9 for b in breaks]]))
    out = design.sample(phi, eccentricity)
    signs = STROKE_SIGNS[stroke]
    speeds = np.vstack([s * out["dtheta"] for s in signs] + [np.zeros((1, phi.size))])
    accels = np.vstack([s * out["ddtheta"] for s in signs] + [np.zeros((1, phi.size))])
    active = speeds.argmax(axis=0)
    cols = np.arange(phi.size)
    speed = speeds[active, cols]
    position = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(phi))])
    theta = np.unwrap(out["theta"], axis=1)
    return Curves(design.mechanism, design.model.count_variable, stroke, eccentricity, phi,
                  theta, out["dtheta"], out["ddtheta"], position, speed, accels[active, cols])


def plot_curves(curves: Curves, axes=None, title: str = ""):
    """Members (left column) and the freewheel output (right): position, velocity and
    acceleration analogues against the crank angle in degrees. Returns the figure.

    ``axes``: an existing 3×2 array of axes, or None for a new figure.
    """
    plt = pyplot()

    if axes is None:
        fig, axes = plt.subplots(3, 2, figsize=(11, 8), sharex=True, constrained_layout=True)
    else:
        fig = axes[0][0].figure
    deg = np.degrees(curves.phi)
    n = curves.theta.shape[0]
    names = [rf"$\theta_{{{k + 1}}}$" for k in range(n)]
    left = (("θ, deg", np.degrees(curves.theta)), ("dθ/dφ", curves.dtheta),
            ("d²θ/dφ², 1/rad", curves.ddtheta))
    for ax, (label, rows) in zip(axes[:, 0], left):
        for k in range(n):
            ax.plot(deg, rows[k], lw=1.2, label=names[k] if n <= 8 else None)
        ax.set_ylabel(label)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.grid(alpha=0.3)
    if n <= 8:
        axes[0, 0].legend(fontsize=9, ncol=n, loc="lower center", bbox_to_anchor=(0.5, 1.0),
                          frameon=False, title=f"output members ({curves.member} = {n})",
                          title_fontsize=10)
    right = (("Φ, deg", np.degrees(curves.output_position)), ("Φ' = ω_out/ω1", curves.output_speed),
             ("Φ'', 1/rad", curves.output_acceleration))
    for ax, (label, values) in zip(axes[:, 1], right):
        ax.plot(deg, values, color="k", lw=1.4)
        ax.set_ylabel(label)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.grid(alpha=0.3)
    axes[0, 1].set_title(f"freewheel output, stroke {curves.stroke}")
    for ax in axes[-1]:
        ax.set_xlabel("crank angle φ, deg")
        ax.set_xlim(0, 360)
        ax.set_xticks(range(0, 361, 60))
    fig.suptitle(title or f"{curves.mechanism}, eccentricity {curves.eccentricity:g}")
    return fig
