"""Figure of the cardan shaft's bend and principal imbalance against its speed (eqs. 14, 15, 18).

matplotlib is imported inside the function (never by ``analyze``); the figure is built on a
bare :class:`matplotlib.figure.Figure`, so no GUI backend is touched.
"""
from __future__ import annotations

from optdesign.driveline.model import PRINCIPAL_IMBALANCE_FACTOR
from optdesign.driveline.section import G_MM_PER_KG_M


def plot_driveline(section, ax=None, operating_speed: float | None = None,
                   speed_limit: float | None = None, upper_fraction: float = 0.95):
    """y_max and D0 of ``section`` (a :class:`DrivelineSection`) from rest to 0.95·ω_cr.

    The left axis is the mid-span bend y_max (mm) of a shaft balanced at low speed (eq. 14)
    and of one balanced at each speed (eq. 18); the right axis reads the first curve as the
    principal imbalance D0 = (5/8)·m·y_max (g·mm, eq. 15), which is proportional to it.
    Optional vertical marks: the operating speed and the allowed speed limit (rad/s).
    Returns the figure.
    """
    if ax is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(7.0, 4.5), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    c = section.speed_curves(upper_fraction)
    w_cr = c["critical_speed_rad_s"]
    ax.plot(c["omega_rad_s"], c["y_max_mm"], color="C0", lw=2,
            label="y_max, D0: unbalanced or balanced at low speed (eqs. 14, 15)")
    ax.plot(c["omega_rad_s"], c["y_max_balanced_mm"], color="C0", lw=1.5, ls="--",
            label="y_max balanced at that speed (eq. 18)")
    ax.axhline(section.y0_max * 1e3, color="0.5", lw=0.8, ls=":",
               label=f"initial bend y0_max = {section.y0_max * 1e3:.3g} mm (eq. 11)")
    marks = [(section.balancing_speed, "balancing", "C2"),
             (operating_speed, "operating", "C3"), (speed_limit, "allowed", "C1")]
    for omega, name, colour in marks:
        if omega and omega <= c["omega_rad_s"][-1]:
            ax.axvline(omega, color=colour, lw=1.0, ls="-.",
                       label=f"{name} speed {omega:.4g} rad/s")
    ax.set_xlim(0.0, c["omega_rad_s"][-1])
    ax.set_ylim(0.0, 1.05 * c["y_max_mm"].max())
    ax.set_xlabel(f"shaft speed ω, rad/s (first critical ω_cr = {w_cr:.5g} rad/s)")
    ax.set_ylabel("mid-span bend y_max, mm")
    to_imbalance = PRINCIPAL_IMBALANCE_FACTOR * section.mass * G_MM_PER_KG_M * 1e-3
    right = ax.secondary_yaxis("right", functions=(lambda y: y * to_imbalance,
                                                   lambda d: d / to_imbalance))
    right.set_ylabel("principal imbalance D0, g·mm")
    top = ax.secondary_xaxis("top", functions=(lambda w: w / w_cr, lambda r: r * w_cr))
    top.set_xlabel("ω / ω_cr")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    return fig
