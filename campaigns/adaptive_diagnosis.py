"""Diagnosis of the adaptive step's error estimate (time_schemes/time_control.py), for campaigns/adaptive_ladder.py.

``diagnose``: where one step's estimate from a checkpoint lives: the regions of the channel, other floors, and
each component weighted by its own magnitude (the estimate's first weighting, which let the wake's zero
crossings decide CFD3's step) instead of by its node's.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


REGIONS = ((-1.0, 0.25, "x < 0.25 (inlet, cylinder)"), (0.25, 0.6, "0.25–0.6 (beside the flag)"),
           (0.6, 1.2, "0.6–1.2 (near wake)"), (1.2, 9.0, "x > 1.2 (far wake)"))


def diagnose(run_dir: Path, dts: list[float]) -> str:
    """Where the error estimate of one step from ``run_dir``'s checkpoint lives (serial): the step attempted at
    each δt of ``dts`` (the controller's proposal first), E as the controller computes it, E with other floors
    and with each component weighted by its own magnitude, and the share of Σ ratio² and of the nodes per
    region of the channel."""
    sys.path.insert(0, str(ROOT / "campaigns"))
    from fsi_time_ladder import checkpointed

    _, sim, states = checkpointed(run_dir)
    sim.restore(states)
    stepper, control = sim.stepper, sim.time_control
    state, steps = sim.state, sim.state.steps
    control.t_end = np.inf  # a checkpoint at the run's end: the step the controller would take next
    V = state.velocity.function_space
    x = V.tabulate_dof_coordinates()[: V.dofmap.index_map.size_local, 0]
    lines = [f"{run_dir.name} at t = {state.t:.5g} (steps {steps.before:.4g}, {steps.last:.4g}; proposed "
             f"{control.proposal(state):.4g}; per-step tolerance {control.step_tolerance:.3g})", "",
             "| δt | E (controller) | E floor 0.1 | E floor 1 | E per component | "
             + " | ".join(f"share {name} (controller / per component)" for *_, name in REGIONS) + " |",
             "|---" * (5 + len(REGIONS)) + "|"]
    for dt in [control.proposal(state)] + dts:
        stepper.dt = dt
        stepper._attempt()
        parts = control.parts(stepper)[:1]  # the velocity's
        (diff, new), = parts
        weight = control.weights(parts)[0][:, None]
        per_component = np.abs(new) + control.floor * np.abs(new).max()
        r2, s2 = ((diff / weight) ** 2).sum(axis=1), ((diff / per_component) ** 2).sum(axis=1)
        regions = [(x >= a) & (x < b) for a, b, _ in REGIONS]
        lines.append(f"| {dt:.4g} | {control.error(stepper):.3g} | "
                     f"{control.norm(parts, control.weights(parts, 0.1)):.3g} | "
                     f"{control.norm(parts, control.weights(parts, 1.0)):.3g} | "
                     f"{float(np.sqrt(np.mean((diff / per_component) ** 2))) / control.step_tolerance:.3g} | "
                     + " | ".join(f"{100 * r2[k].sum() / r2.sum():.0f} / {100 * s2[k].sum() / s2.sum():.0f} % "
                                  f"({100 * k.mean():.0f} % of the nodes)" for k in regions) + " |")
        stepper._rejected()
    return "\n".join(lines)
