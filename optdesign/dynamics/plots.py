"""Figures of the steady cycle, after the paper's Fig. 2 (angles) and Fig. 3 (speeds).

Plot functions take a :class:`~optdesign.dynamics.steady.SimulationResult`, accept ``ax=None``
and return the figure; matplotlib is imported here only, with the Agg backend.
"""
from __future__ import annotations

import numpy as np
from optdesign.figures.design import pyplot


def _axes(ax, figsize):  # noqa: D401 - one axes, made if not given
    plt = pyplot()

    if ax is None:
        fig, ax = plt.subplots(figsize=figsize, constrained_layout=True)
    return ax.figure, ax


def _which(result) -> str:
    turns = f" of {result.period_turns} turns" if result.period_turns > 1 else ""
    if result.steady:
        return f"the steady cycle{turns}"
    return f"turn {result.cycles} ({result.status.replace('_', ' ')})"


def _driving(result):
    """The angle of the driving holder in output coordinates, ψ + ε of the engaged freewheel
    with the largest ε (the paper's Φ), NaN while every freewheel overruns."""
    tr = result.trace
    eps = np.where(tr["engaged"], tr["eps"], np.nan)
    lead = np.nanmax(np.where(np.isnan(eps), -np.inf, eps), axis=0)
    lead[~np.isfinite(lead)] = np.nan
    return tr["psi"] + lead


def plot_angles(result, ax=None):
    """Fig. 2: relative angle ε_k of every freewheel (while engaged), output angle ψ and the
    driving holder's angle Φ over the recorded turn (t = 0 at its crank angle 2π·m).

    With ``ax=None`` ψ and Φ go on a top panel and the (much smaller) ε_k on their own scale
    below; on a given ``ax`` everything shares it, as in the paper's figure.
    """
    if ax is None:
        from optdesign.figures.design import pyplot

        fig, (top, bottom) = pyplot().subplots(2, 1, figsize=(7.5, 5.6), sharex=True,
                                               constrained_layout=True,
                                               gridspec_kw={"height_ratios": [3, 2]})
    else:
        fig, top, bottom = ax.figure, ax, ax
    tr = result.trace
    t = tr["t"]
    top.plot(t, tr["psi"], color="k", lw=1.6, label="ψ (output shaft)")
    top.plot(t, _driving(result), color="0.55", lw=1.2, ls="--", label="Φ (driving holder)")
    for k, label in enumerate(result.labels):
        eps = np.where(tr["engaged"][k], tr["eps"][k], np.nan)
        bottom.plot(t, eps, lw=1.4, label=f"ε{label}" if len(result.labels) > 1 else "ε")
    top.set_title(f"{result.name}: angles over {_which(result)} "
                  f"({result.freewheel} freewheels, ε_max = {result.eps_max:.4g} rad)",
                  fontsize=10)
    top.set_ylabel("angle, rad")
    bottom.set_ylabel("relative angle ε, rad" if bottom is not top else "angle, rad")
    bottom.set_xlabel("t, s")
    for a in {top, bottom}:
        a.grid(alpha=0.3)
        a.legend(fontsize=8, ncol=2 if len(result.labels) > 3 else 1, loc="upper left")
    return fig


def plot_speeds(result, ax=None):
    """Fig. 3: output speed ψ̇ and the driving-holder speeds u_k'·φ̇ over the steady cycle,
    the crank speed φ̇ on a second axis."""
    fig, ax = _axes(ax, (7.5, 4.2))
    tr = result.trace
    t = tr["t"]
    for k, label in enumerate(result.labels):
        ax.plot(t, tr["holder_speed"][k], lw=0.9, alpha=0.7, label=f"holder {label}")
    ax.plot(t, tr["omega_out"], color="k", lw=1.8, label="dψ/dt (output shaft)")
    ax.axhline(result.omega_out_mean, color="k", lw=0.8, ls=":")
    top = max(tr["omega_out"].max(), 0.0)
    ax.set_ylim(min(tr["omega_out"].min(), 0.0) - 0.05 * top, 1.25 * top + 1e-12)
    ax.set_xlabel("t, s")
    ax.set_ylabel("output side speed, rad/s")
    ax.grid(alpha=0.3)
    crank = ax.twinx()
    crank.plot(t, tr["omega_in"], color="tab:red", lw=1.0, ls="--", label="dφ/dt (crank)")
    crank.set_ylabel("crank speed dφ/dt, rad/s", color="tab:red")
    crank.tick_params(axis="y", colors="tab:red")
    lines = ax.get_legend_handles_labels()
    more = crank.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], fontsize=8, loc="upper right",
              ncol=2 if len(result.labels) > 3 else 1)
    ax.set_title(f"{result.name}: speeds over {_which(result)}; δ = "
                 f"{result.dynamic.delta:.3f} dynamic, {result.kinematic.delta:.3f} kinematic",
                 fontsize=10)
    return fig


def plot_loads(result):
    """What sizes the parts over the steady cycle: each freewheel's torque against time, and
    the peak force of every joint (links massless), pivots and pins apart."""
    plt = pyplot()
    joints = (result.loads or {}).get("joints") or []
    fig, axes = plt.subplots(1, 2 if joints else 1, figsize=(12 if joints else 7.5, 4.2),
                             squeeze=False)
    ax = axes[0, 0]
    tr = result.trace
    for k, label in enumerate(result.labels):
        torque = tr["freewheel_torque"][k]
        if np.any(torque > 0):
            ax.plot(tr["t"], torque, lw=1.2, label=f"freewheel {label}")
    ax.axhline(result.loads["mean_freewheel_torque_n_m"], color="k", lw=0.8, ls=":",
               label="mean of their sum")
    ax.set_xlabel("t, s")
    ax.set_ylabel("freewheel torque λ·ε, N·m")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"{result.name}: freewheel torques over {_which(result)}", fontsize=10)
    if joints:
        bx = axes[0, 1]
        names = [j["joint"] for j in joints]
        colours = ["0.45" if j["kind"] == "pivot" else "tab:blue" for j in joints]
        bx.bar(names, [j["peak_force_n"] for j in joints], color=colours)
        bx.set_ylabel("peak force, N")
        bx.set_title("peak joint forces (grey: pivots, blue: pins)", fontsize=10)
        bx.tick_params(axis="x", labelsize=8, rotation=90)
        bx.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig
