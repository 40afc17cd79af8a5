"""Diagnosis of the adaptive step's error estimate (scheme/time_control.py), for campaigns/adaptive_ladder.py.

``diagnose``: where one step's estimate from a checkpoint lives (regions of the channel, other floors, node
weights); ``node_weighted_error``: a trial estimate with each node's magnitude as the weight of its components
(``adaptive_ladder.py --one ... --node-weights``), for comparison with the shipped per-component weights.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def node_weighted_error(self, stepper):
    """A trial (``--node-weights``) of TimeControl.error with each node's magnitude |u(x_i)| (|d(x_i)|) as the
    weight of all its components instead of each component's own |u_i|: otherwise the same E."""
    from mpi4py import MPI

    from cosserat_fsi.scheme.variable_step import estimate_factor, predicted

    state, order = stepper.state, self.order
    if state.step_count < order:
        return None
    steps, dt = state.steps, stepper.dt
    factor = estimate_factor(order, dt, steps.last, steps.before)
    V = state.velocity.function_space
    bs = V.dofmap.index_map_bs
    owned = V.dofmap.index_map.size_local * bs
    levels = [state.velocity, state.velocity_prev, state.velocity_prev2]
    parts = [(stepper._new_velocity()[:owned], predicted(order, dt, steps.last, steps.before, *[
        f.x.array[:owned] if f is not None else None for f in levels]), bs)]
    d_new = stepper.candidate_displacement()
    if d_new is not None:
        nodes = stepper.problem.solid_velocity_dofs
        mine = nodes < V.dofmap.index_map.size_local
        dim = d_new.shape[1]

        def at_nodes(f):
            return None if f is None else f.x.array.reshape(-1, dim)[nodes[mine]].ravel()
        parts.append((d_new[mine].ravel(), predicted(order, dt, steps.last, steps.before, *map(
            at_nodes, (state.displacement, state.displacement_prev, state.displacement_prev2))), dim))
    scales = self.comm.allreduce(np.array([np.abs(new).max(initial=0.0) for new, *_ in parts]), op=MPI.MAX)
    sums = np.zeros(2 * len(parts))
    for i, ((new, guess, block), scale) in enumerate(zip(parts, scales)):
        weight = np.linalg.norm(new.reshape(-1, block), axis=1).repeat(block) + self.floor * scale
        ratio = np.divide(factor * (new - guess), weight, out=np.zeros_like(new), where=weight > 0.0)
        sums[2 * i:2 * i + 2] = (ratio @ ratio, len(new))
    sums = self.comm.allreduce(sums, op=MPI.SUM)
    return float(np.sqrt(sums[0::2].sum() / max(sums[1::2].sum(), 1.0))) / self.step_tolerance



REGIONS = ((-1.0, 0.25, "x < 0.25 (inlet, cylinder)"), (0.25, 0.6, "0.25–0.6 (beside the flag)"),
           (0.6, 1.2, "0.6–1.2 (near wake)"), (1.2, 9.0, "x > 1.2 (far wake)"))


def diagnose(run_dir: Path, dts: list[float]) -> str:
    """Where the error estimate of one step from ``run_dir``'s checkpoint lives (serial): the step attempted at
    each δt of ``dts`` (the controller's proposal first), E as the controller computes it, E with other floors
    and with each node's speed as the weight of both components, and the share of Σ ratio² and of the dofs
    per region of the channel."""
    sys.path.insert(0, str(ROOT / "campaigns"))
    from fsi_time_ladder import checkpointed

    from cosserat_fsi.scheme.variable_step import estimate_factor, predicted

    _, sim, states = checkpointed(run_dir)
    sim.restore(states)
    stepper, control = sim.stepper, sim.time_control
    state, steps = sim.state, sim.state.steps
    control.t_end = np.inf  # a checkpoint at the run's end: the step the controller would take next
    V = state.velocity.function_space
    bs = V.dofmap.index_map_bs
    owned = V.dofmap.index_map.size_local * bs
    x = V.tabulate_dof_coordinates()[: owned // bs, 0].repeat(bs)
    lines = [f"{run_dir.name} at t = {state.t:.5g} (steps {steps.before:.4g}, {steps.last:.4g}; proposed "
             f"{control.proposal(state):.4g}; per-step tolerance {control.step_tolerance:.3g})", "",
             "| δt | E (controller) | E floor 0.1 | E floor 1 | E node speed, floor 0.01 | "
             + " | ".join(f"share {name} (controller / node speed)" for *_, name in REGIONS) + " |",
             "|---" * (5 + len(REGIONS)) + "|"]
    for dt in [control.proposal(state)] + dts:
        stepper.dt = dt
        stepper._attempt()
        e = control.error(stepper)
        new = stepper._new_velocity()[:owned]
        guess = predicted(control.order, dt, steps.last, steps.before, *[
            f.x.array[:owned] for f in (state.velocity, state.velocity_prev, state.velocity_prev2)])
        diff = estimate_factor(control.order, dt, steps.last, steps.before) * (new - guess)
        top = np.abs(new).max()
        speed = np.linalg.norm(new.reshape(-1, bs), axis=1).repeat(bs)

        def rms(weight, diff=diff):
            return float(np.sqrt(np.mean((diff / weight) ** 2))) / control.step_tolerance

        r2 = (diff / (np.abs(new) + control.floor * top)) ** 2
        s2 = (diff / (speed + control.floor * top)) ** 2
        regions = [(x >= a) & (x < b) for a, b, _ in REGIONS]
        lines.append(f"| {dt:.4g} | {e:.3g} | {rms(np.abs(new) + 0.1 * top):.3g} | {rms(np.abs(new) + top):.3g} | "
                     f"{rms(speed + control.floor * top):.3g} | " + " | ".join(
                         f"{100 * r2[k].sum() / r2.sum():.0f} / {100 * s2[k].sum() / s2.sum():.0f} % "
                         f"({100 * k.mean():.0f} % of the dofs)" for k in regions) + " |")
        stepper._rejected()
    return "\n".join(lines)
