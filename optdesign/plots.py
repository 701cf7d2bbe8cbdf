"""Figures of a design: rocker speeds with the output envelope, and drawings of the linkage.

Plot functions take data, accept ``ax=None`` and return the figure; matplotlib is imported
only here, and only when a plot is made.
"""
from __future__ import annotations

import numpy as np

from .envelope import output_envelope
from .mechanisms import STROKE_SIGNS


def pyplot():
    """matplotlib.pyplot, imported on first use. The backend is never switched here: a
    notebook keeps its own (the ``optdesign`` command selects Agg, files only, before any
    figure is made)."""
    import matplotlib.pyplot as plt
    return plt


def plot_speeds(design, stroke: str, input_speed: float, eccentricity: float = 1.0,
                ax=None, n_samples: int = 1441, title: str | None = None):
    """Each rocker's driving speed s·ω_k over the crank angle, and the output envelope."""
    plt = pyplot()
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(8, 4.5))
    phi = np.linspace(0, 2 * np.pi, n_samples)
    dtheta = design.sample(phi, eccentricity)["dtheta"]
    deg = np.degrees(phi)
    for s in STROKE_SIGNS[stroke]:
        for k in range(dtheta.shape[0]):
            ax.plot(deg, s * dtheta[k] * input_speed, lw=0.9, alpha=0.6,
                    label=f"member {k + 1}" if s == STROKE_SIGNS[stroke][0] else None)
    env = output_envelope(dtheta, stroke) * input_speed
    ax.plot(deg, env, color="black", lw=2.4, label="output (envelope)")
    lo, hi = env.min(), env.max()
    ax.axhline(hi, color="black", ls=":", lw=0.8)
    ax.axhline(lo, color="black", ls=":", lw=0.8)
    ax.set_ylim(min(0.0, lo) - 0.05 * hi, hi * 1.08)
    ax.set_xlim(0, 360)
    ax.set_xticks(range(0, 361, 45))
    ax.set_xlabel("crank angle φ1 [deg]")
    ax.set_ylabel("driving speed [rad/s]" if stroke == "both" else
                  f"speed in the {stroke} direction [rad/s]")
    ax.set_title(title or f"{stroke} stroke, eccentricity {eccentricity:g}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=5, loc="upper center", bbox_to_anchor=(0.5, -0.14),
              frameon=False)
    return fig


def plot_mechanism(design, angles_deg=(0, 90, 180, 270), eccentricity: float = 1.0,
                   axes=None, title: str | None = None):
    """The linkage drawn at a few crank angles (one panel each), to scale, in mm."""
    plt = pyplot()
    if axes is None:
        fig, axes = plt.subplots(1, len(angles_deg), figsize=(3.6 * len(angles_deg), 3.8))
    axes = np.atleast_1d(axes)
    fig = axes[0].figure
    fn, names, links = design.model.joints(design.count, design.option_key)
    p = design.p(eccentricity)
    for ax, angle in zip(axes, angles_deg):
        pts = dict(zip(names, np.array(fn(np.radians(angle), p)).T))
        for a, b in links:
            ax.plot(*np.c_[pts[a], pts[b]], color="tab:blue", lw=1.6)
        fixed = [k for k in pts if k == "O" or (k.startswith("O") and k[1:].isdigit())]
        for k, xy in pts.items():
            ax.plot(*xy, "o", ms=3.5, color="black" if k in fixed else "tab:orange")
        ax.set_aspect("equal")
        ax.set_title(f"φ1 = {angle:g}°", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.2)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig
