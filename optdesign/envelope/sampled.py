"""The freewheel output and its ripple (docs/formulation.md), on samples of the crank angle.

With ideal freewheels the output turns at the speed of the fastest rocker in the driving
direction: ω_out(φ) = max(0, max_k s·ω_k(φ)), s = +1 forward stroke, -1 reverse stroke (both
signs for ``both``). The 0 is the output at rest while every freewheel overruns (only possible
with few phases). Ripple, the coefficient of velocity fluctuation (Sharkov & Kalinin 2022, the
formula after eq. 8; Artobolevsky): δ = (ω_max - ω_min)/ω_mid, with ω_mid the midrange
(ω_max + ω_min)/2 (paper, ``midrange``) or the time mean ω_mean (``mean``).

Words: ``omega_midrange`` is the midrange (the paper's ω_ср), ``omega_mean`` the time mean.
``omega_avg`` is the midrange's old name, kept one more release as a deprecated alias.
"""
from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass

import numpy as np

#: Signs applied to the rocker speeds for each stroke: the freewheels pass the rocker's motion
#: in that direction only; ``both`` is a second output shaft through a 1:1 reversing gear pair.
STROKE_SIGNS: dict[str, tuple[int, ...]] = {"forward": (1,), "reverse": (-1,), "both": (1, -1)}


def ripple_of(omega_max, omega_min, omega_mean, definition: str = "midrange"):
    """δ = (ω_max − ω_min)/ω_mid, the coefficient of velocity fluctuation (Sharkov & Kalinin
    2022, the formula after eq. 8), ω_mid the midrange (ω_max + ω_min)/2 (``midrange``, the
    paper's) or the time mean (``mean``). Arithmetic only: the one formula for numbers, NumPy
    arrays of many designs (screening, Monte Carlo) and CasADi symbols (the NLP)."""
    mid = 0.5 * (omega_max + omega_min) if definition == "midrange" else omega_mean
    return (omega_max - omega_min) / mid


@dataclass(frozen=True)
class StrokeFigures:
    """Output-speed figures of one stroke, speeds in rad/s."""

    omega_max: float
    omega_min: float
    omega_midrange: float  # (ω_max + ω_min)/2, the paper's ω_ср
    omega_mean: float      # time mean over a turn
    delta: float           # (ω_max - ω_min)/omega_midrange
    delta_mean: float      # (ω_max - ω_min)/ω_mean
    ratio: float           # ω_mean / ω1: output speed / input speed (the gear ratio i = 1/ratio)

    @classmethod
    def from_extremes(cls, omega_max, omega_min, omega_mean, input_speed) -> "StrokeFigures":
        midrange = 0.5 * (omega_max + omega_min)

        def ripple(definition, mid):
            return float(ripple_of(omega_max, omega_min, omega_mean, definition)) \
                if mid > 0 else float("inf")

        return cls(float(omega_max), float(omega_min), float(midrange), float(omega_mean),
                   ripple("midrange", midrange), ripple("mean", omega_mean),
                   float(omega_mean / input_speed))

    @property
    def omega_avg(self) -> float:
        """Deprecated: the midrange's old name; use :attr:`omega_midrange`."""
        warnings.warn("StrokeFigures.omega_avg is deprecated; use omega_midrange (the "
                      "midrange; omega_mean is the time mean)", DeprecationWarning, stacklevel=2)
        return self.omega_midrange

    def ripple(self, definition: str) -> float:
        return self.delta if definition == "midrange" else self.delta_mean

    def to_dict(self) -> dict:
        """The figures by name, with ``omega_avg`` beside ``omega_midrange`` (deprecated
        alias, to be removed in the next release)."""
        out = {}
        for key, value in asdict(self).items():
            out[key] = value
            if key == "omega_midrange":
                out["omega_avg"] = value
        return out


def driving_speeds(dtheta: np.ndarray, stroke: str) -> np.ndarray:
    """Rows s·dθ_k/dφ for every chain k and sign s of the stroke (speed per unit ω1).

    The forward stroke's rows are ``dtheta`` itself, not a copy (1·x is x to the bit): the
    screening's arrays hold 24 chains × a hundred thousand crank samples, and a copy of them,
    written to fresh memory, costs more than the arithmetic. Read the result, never write it.
    The other strokes' rows are each sign's product written straight into the one array
    returned (the same products as stacked ones, without a temporary per sign and the copy
    that stacks them: a tenth of the time for both strokes).
    """
    signs = STROKE_SIGNS[stroke]
    if signs == (1,):
        return np.asarray(dtheta)
    rows = np.atleast_2d(dtheta)                # (a single curve is one row, as stacked)
    n = rows.shape[0]
    out = np.empty((len(signs) * n,) + rows.shape[1:], dtype=np.result_type(rows, signs[0]))
    for i, s in enumerate(signs):
        np.multiply(rows, s, out=out[i * n:(i + 1) * n])
    return out


def output_envelope(dtheta: np.ndarray, stroke: str) -> np.ndarray:
    """ω_out/ω1 = max(0, max_k s·dθ_k/dφ) at each sample."""
    return np.maximum(driving_speeds(dtheta, stroke).max(axis=0), 0.0)


def sampled_figures(design, stroke: str, input_speed: float, n_samples: int = 360,
                    eccentricity: float = 1.0) -> StrokeFigures:
    """Figures from N equally spaced crank samples (the NLP's view; error O(1/N²) at smooth
    extremes, O(1/N) at the kinks where two rocker curves cross)."""
    phi = np.linspace(0.0, 2 * np.pi, n_samples, endpoint=False)
    env = output_envelope(design.sample(phi, eccentricity)["dtheta"], stroke) * input_speed
    return StrokeFigures.from_extremes(env.max(), env.min(), env.mean(), input_speed)
