"""What sizes the parts: the freewheels' torques and the joints' forces over the steady cycle.

Freewheel k transmits T_k = λ_k·ε_k + c_k·ε̇_k while engaged (the model's torque,
:mod:`optdesign.dynamics.model`), nothing while released. Over the recorded cycle each
freewheel's peak torque and its engagement share (the share of the cycle's time it is engaged)
are reported; over a steady cycle the freewheels' mean total torque equals the mean load (the
output's speed repeats, so I2·Δψ̇ = 0 = ∫(Σ T_k − T_c) dt).

With one freewheel per output member (the ``ratchet`` model), member k delivers the torque
M_k = g·s·T_k to its freewheel (g the reduction, s the stroke's sign: the power T_k·u̇_k with
u_k = g·s·θ_k), and the mechanism's quasi-static analysis
(:meth:`optdesign.mechanisms.base.Mechanism.joint_forces`, links massless) gives the force in
every pivot and pin at each sample; their peaks are reported.
"""
from __future__ import annotations

import numpy as np


def holder_slopes(model, phi: np.ndarray) -> np.ndarray:
    """u_k'(φ) per freewheel and crank angle: the holders' angle per radian of crank."""
    return np.array([model.holders(p)[1] for p in phi]).T                  # (wheels, N)


def freewheel_torques(model, trace: dict, du: np.ndarray) -> np.ndarray:
    """T_k per freewheel and recorded sample (N·m): λ_k·ε_k + c_k·ε̇_k while engaged, with
    ε̇_k = u_k'·φ̇ − ψ̇ (``du``: :func:`holder_slopes` at the samples)."""
    rel_speed = du * trace["omega_in"] - trace["omega_out"]
    torque = model.stiffness[:, None] * trace["eps"] + model.damping[:, None] * rel_speed
    return np.where(trace["engaged"], torque, 0.0)


def loads(design, model, trace: dict, reduction: float,
          switches: list = ()) -> tuple[dict, dict]:
    """(the summary, the series per sample: ``freewheel_torque`` and ``joint_forces``).

    The summary: ``freewheels`` (per freewheel: its label, ``peak_torque_n_m``, the crank angle of the
    peak, ``engaged_share``; the peak is the larger of the samples' and λ·ε at each located
    maximum of ε among ``switches``, where ε̇ = 0), ``mean_freewheel_torque_n_m`` (the cycle's mean of Σ T_k),
    ``peak_crank_torque_n_m`` (the freewheels' reaction on the crank, Σ T_k·u_k') and
    ``joints`` (per joint: ``peak_force_n`` and its kind), or ``joints_note`` saying why
    there are none."""
    t = np.asarray(trace["t"], dtype=float)
    du = holder_slopes(model, trace["phi"])
    torque = freewheel_torques(model, trace, du)
    dt = np.diff(t)
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    labels = model.labels()
    engaged = np.asarray(trace["engaged"], dtype=bool)
    freewheels = []
    for k, label in enumerate(labels):
        j = int(np.argmax(torque[k]))
        peak, at = float(torque[k, j]), float(np.degrees(trace["phi"][j]) % 360.0)
        for event in switches:
            if event["kind"] == "eps_max" and event["freewheel"] == label and \
                    model.stiffness[k] * event["eps"] > peak:
                peak, at = float(model.stiffness[k] * event["eps"]), event["phi_deg"] % 360.0
        share = float((dt * engaged[k, :-1]).sum() / span) if span > 0 else float("nan")
        freewheels.append({"freewheel": label, "peak_torque_n_m": peak,
                           "peak_at_phi_deg": at, "engaged_share": share})
    total = torque.sum(axis=0)
    mean = float(np.trapezoid(total, t) / span) if span > 0 else float("nan")
    out = {"freewheels": freewheels, "mean_freewheel_torque_n_m": mean,
           "peak_crank_torque_n_m": float((torque * du).sum(axis=0).max())}
    series = {"freewheel_torque": torque, "joint_forces": {}}
    if model.composite:
        out["joints"] = None
        out["joints_note"] = ("the composite freewheel model has one freewheel on the whole "
                              "converter: its torque is not split between the members")
        return out, series
    positions = joint_positions(design, trace["phi"])
    forces = design.model.joint_forces(positions, rocker_torques(model, torque, reduction))
    if forces is None:
        out["joints"] = None
        out["joints_note"] = f"{design.mechanism} has no joint force analysis yet"
        return out, series
    series["joint_forces"] = forces
    fixed = {name for name, xy in positions.items()            # a pivot does not move
             if np.ptp(xy, axis=1).max() <= 1e-9 * max(1.0, np.abs(xy).max())}
    out["joints"] = [{"joint": name, "kind": "pivot" if name in fixed else "pin",
                      "peak_force_n": float(np.max(f)),
                      "peak_at_phi_deg": float(np.degrees(trace["phi"][int(np.argmax(f))])
                                               % 360.0)}
                     for name, f in sorted(forces.items(), key=lambda kv: _joint_order(kv[0]))]
    return out, series


def rocker_torques(model, torque: np.ndarray, reduction: float) -> np.ndarray:
    """M_k = Σ over member k's freewheels of g·s·T (N·m), per member and sample."""
    holders = model.holders
    out = np.zeros((int(holders.chain.max()) + 1, torque.shape[1]))
    for w in range(torque.shape[0]):
        out[holders.chain[w]] += reduction * holders.signs[w] * torque[w]
    return out


def joint_positions(design, phi: np.ndarray) -> dict:
    """Every joint's position (mm, ``{name: (2, samples)}``) at the crank angles ``phi``
    (e = 1, as the drive runs)."""
    fn, names, _ = design.model.joints(design.count, design.option_key)
    phi = np.asarray(phi, dtype=float)
    points = np.array(fn.map(phi.size)(phi[None, :], design.p(1.0))).reshape(2, phi.size,
                                                                             len(names))
    return {name: points[:, :, i] for i, name in enumerate(names)}


def _joint_order(name: str) -> tuple:
    """O, A, then each chain's joints in order (O1, B1, C2, B2, O2, ...)."""
    digits = "".join(c for c in name if c.isdigit())
    return (int(digits) if digits else 0, name)
