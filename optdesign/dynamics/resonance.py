"""The drive's natural frequencies beside the pulse frequency: is the output shaken at
resonance?

The dynamic model is two masses, the input side I1 (motor, crank, converter) and the output
side I2, joined through an engaged freewheel of stiffness λ (Ambartsumyants & Subbotina 2015,
eqs. 1-3). While a freewheel transmits, the output side rings against it at

* ω_out = √(λ/I2), the output on the freewheel with the input side held (I1 ≫ I2), and
* ω_2m = √(λ·(I1 + I2)/(I1·I2)), the two masses against each other (the free-free mode),

and the rockers hand over n times a crank turn (2n for a mechanism whose both strokes drive),
so the output is driven at the pulse frequency n·ω1 and its harmonics k·n·ω1. A harmonic
within :data:`MARGIN` of ω_out is near resonance (the two-mass mode is reported beside it: the
crank's inertia, reduced through the linkage, holds the input side against the pulses far
more than I1 alone suggests, and the simulated drives ring at ω_out): the dynamic ripple then grows
well past the kinematic one (Den Hartog, Mechanical Vibrations, 1956, ch. 2: the steady
amplitude of an undamped oscillator driven at ω is 1/|1 − (ω/ω_n)²| times the static one).
"""
from __future__ import annotations

import math

#: a pulse harmonic within this fraction of a natural frequency is near resonance (±15 %:
#: the undamped magnification 1/|1 − r²| is at least 3 there)
MARGIN = 0.15
#: pulse harmonics compared
HARMONICS = 3


def natural_frequencies(I1: float, I2: float, stiffness: float) -> dict[str, float]:
    """``output_rad_s`` √(λ/I2) and ``two_mass_rad_s`` √(λ(I1 + I2)/(I1·I2))."""
    return {"output_rad_s": math.sqrt(stiffness / I2),
            "two_mass_rad_s": math.sqrt(stiffness * (I1 + I2) / (I1 * I2))}


def resonance(I1: float, I2: float, stiffness: float, pulses_per_turn: int,
              omega_in: float) -> dict:
    """The natural frequencies, the pulse frequency ``pulses_per_turn``·``omega_in`` and its
    harmonics (rad/s), the harmonic closest to ω_out, and ``near`` when it lies within
    :data:`MARGIN` of it."""
    natural = natural_frequencies(I1, I2, stiffness)
    pulse = pulses_per_turn * omega_in
    harmonics = [k * pulse for k in range(1, HARMONICS + 1)]
    out = natural["output_rad_s"]
    pairs = [(abs(h / out - 1.0), k + 1, "output", out, h)
             for k, h in enumerate(harmonics)]
    gap, k, name, w, h = min(pairs)
    return {"natural_rad_s": natural, "pulse_rad_s": pulse, "harmonics_rad_s": harmonics,
            "pulses_per_turn": pulses_per_turn, "margin": MARGIN,
            "closest": {"mode": name, "natural_rad_s": w, "harmonic": k,
                        "harmonic_rad_s": h, "relative_gap": gap},
            "near": gap <= MARGIN}


def resonance_text(doc: dict, delta_dynamic: float, delta_kinematic: float) -> list[str]:
    """The terminal's lines: the frequencies, and a warning with the dynamic/kinematic δ
    ratio when a pulse harmonic is near a natural frequency."""
    nat = doc["natural_rad_s"]
    c = doc["closest"]
    lines = [f"  frequencies      natural √(λ/I2) = {nat['output_rad_s']:.1f} rad/s, two-mass "
             f"{nat['two_mass_rad_s']:.1f} rad/s; pulses {doc['pulses_per_turn']}·ω1 = "
             f"{doc['pulse_rad_s']:.1f} rad/s (harmonics "
             + ", ".join(f"{h:.1f}" for h in doc["harmonics_rad_s"]) + ")"]
    if doc["near"]:
        ratio = delta_dynamic / delta_kinematic if delta_kinematic else float("inf")
        lines.append(f"warning: near resonance: pulse harmonic {c['harmonic']} at "
                     f"{c['harmonic_rad_s']:.1f} rad/s lies {100 * c['relative_gap']:.0f} % from "
                     f"the {'output' if c['mode'] == 'output' else 'two-mass'} natural "
                     f"frequency {c['natural_rad_s']:.1f} rad/s (within "
                     f"{100 * doc['margin']:.0f} %); dynamic δ / kinematic δ = {ratio:.2f}. "
                     f"Change I2, the freewheel stiffness, the phase count or the speed")
    return lines


def plot_frequencies(doc: dict, title: str = "", ax=None):
    """The natural frequencies (vertical lines, ±margin shaded about √(λ/I2)) and the pulse
    harmonics (markers) on one frequency axis."""
    import matplotlib.pyplot as plt

    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(8, 2.8))
    colours = {"output_rad_s": "tab:red", "two_mass_rad_s": "tab:purple"}
    names = {"output_rad_s": "√(λ/I2)", "two_mass_rad_s": "two-mass √(λ(I1+I2)/(I1·I2))"}
    for name, w in doc["natural_rad_s"].items():
        if name == "output_rad_s":      # the mode the warning reads
            ax.axvspan(w * (1 - doc["margin"]), w * (1 + doc["margin"]), color=colours[name],
                       alpha=0.12)
        ax.axvline(w, color=colours[name], lw=2, label=f"natural {names[name]} = {w:.1f} rad/s")
    for k, h in enumerate(doc["harmonics_rad_s"], start=1):
        ax.plot([h], [0.5], "v", ms=11, color="black")
        ax.annotate(f"{k}·{doc['pulses_per_turn']}·ω1\n{h:.1f}", (h, 0.5),
                    textcoords="offset points", xytext=(0, 10), ha="center", fontsize=8)
    top = max(max(doc["harmonics_rad_s"]), max(doc["natural_rad_s"].values())) * 1.35
    ax.set_xlim(0, top)
    ax.set_ylim(0, 1)
    ax.set_yticks([])
    ax.set_xlabel("frequency [rad/s]")
    verdict = "NEAR RESONANCE" if doc["near"] else "clear of resonance"
    ax.set_title(f"{title}{': ' if title else ''}pulse harmonics against the natural "
                 f"frequencies ({verdict}; ±{100 * doc['margin']:.0f} % of √(λ/I2) shaded)", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
    return fig
