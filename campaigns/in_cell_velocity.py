"""Where a flag's in-cell bending lives: the solid velocity's departure from its interpolant linear on each cell.

CSM3's flag (level 0, St Venant–Kirchhoff, μ_s = 0.5e6, λ_s = 2e6, ``ale_bdf2``) at three fixed steps, once with
each ``solid.displacement``. At t = 0.3 it prints, over the solid's nodes, the largest distance of the velocity
and of the displacement from their interpolants linear on each cell (the mid-edge nodes' departure from their
edges' means). With ``quadratic`` the displacement keeps the cells' own bending (its departure the same at
every step) and the velocity's is small. With ``linear`` the displacement's is reset to zero after every step,
so each step's strain gets the bending from (δt/α) u^{n+1}: the velocity's departure is then ≈ α/δt times the
quadratic displacement's, and doubles when δt halves. A change of step changes it at once (a kick), and a
small step makes it large (docs/perf_adaptive_step.md).

    python campaigns/in_cell_velocity.py [--dt 0.01 0.005 0.0025] [--t-end 0.3]
    python campaigns/in_cell_velocity.py --scene SCENE.yaml [--set KEY=VALUE ...] [--last 40]

``--scene``: the scene run to its t_end (or to a divergence) with the in-cell velocity recorded after every
step; prints the last ``--last`` steps (t, δt, in-cell velocity, its product with δt, the largest velocity).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))
sys.path.insert(0, str(ROOT))

import dolfinx  # noqa: E402

from cosserat_fsi import compat  # noqa: E402
from cosserat_fsi.app.runner import load_mesh  # noqa: E402
from cosserat_fsi.config import validate_scene  # noqa: E402
from cosserat_fsi.simulation import Simulation  # noqa: E402


def in_cell_departure(sim, field) -> float:
    """The largest distance, over the solid's nodes, of a P2 vector field from its interpolant linear on
    each cell."""
    V = field.function_space
    dim = V.mesh.geometry.dim
    linear = dolfinx.fem.Function(compat.function_space(V.mesh, "Lagrange", 1, shape=(dim,)))
    back = dolfinx.fem.Function(V)
    linear.interpolate(field)
    back.interpolate(linear)
    nodes = sim.problem.solid_velocity_dofs
    local = np.abs(back.x.array.reshape(-1, dim)[nodes] - field.x.array.reshape(-1, dim)[nodes]).max(initial=0.0)
    return sim.comm.allreduce(local, op=MPI.MAX)


def run(displacement: str, dt: float, t_end: float) -> dict:
    scene = validate_scene({"geometry": {"name": "flag", "level": 0},
                            "solid": {"law": "saint_venant_kirchhoff", "rho": 1000.0, "mu_s": 0.5e6,
                                      "lambda_s": 2.0e6, "gravity": 2.0, "displacement": displacement},
                            "time": {"scheme": "ale_bdf2", "dt": dt, "t_end": t_end}})
    mesh, cell_tags, facet_tags, _ = load_mesh(scene, MPI.COMM_WORLD)
    sim = Simulation(scene, mesh, cell_tags, facet_tags, MPI.COMM_WORLD)
    sim.run(sim.steps_to(t_end))
    velocity = sim.state.velocity.x.array
    return {"velocity": in_cell_departure(sim, sim.state.velocity),
            "largest velocity": sim.comm.allreduce(np.abs(velocity).max(initial=0.0), op=MPI.MAX),
            "displacement": in_cell_departure(sim, sim.state.displacement)}


def scene_rows(path: str, overrides: list[str], last: int) -> list[str]:
    """The scene's run with the in-cell velocity after every step: markdown rows of its last ``last`` steps."""
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.errors import DivergenceError

    scene = load_scene(path, overrides)
    mesh, cell_tags, facet_tags, _ = load_mesh(scene, MPI.COMM_WORLD)
    sim = Simulation(scene, mesh, cell_tags, facet_tags, MPI.COMM_WORLD)
    record, previous = [], [sim.t]

    def after_step(sim):
        velocity = sim.state.velocity
        largest = sim.comm.allreduce(np.abs(velocity.x.array).max(initial=0.0), op=MPI.MAX)
        record.append((sim.t, sim.t - previous[0], in_cell_departure(sim, velocity), largest))
        previous[0] = sim.t

    ending = "completed"
    try:
        sim.run_to(scene.time.t_end, after_step=[after_step])
    except DivergenceError as exc:
        ending = f"diverged: {exc}"
    rows = [f"{ending} ({len(record)} steps)", "",
            "| t | δt | in-cell velocity (m/s) | × δt (m) | largest velocity (m/s) |", "|---|---|---|---|---|"]
    rows += [f"| {t:.6g} | {dt:.3g} | {u:.3g} | {u * dt:.3g} | {top:.3g} |" for t, dt, u, top in record[-last:]]
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dt", type=float, nargs="+", default=[0.01, 0.005, 0.0025])
    parser.add_argument("--t-end", type=float, default=0.3)
    parser.add_argument("--scene", help="a scene file: its run with the in-cell velocity recorded")
    parser.add_argument("--set", action="append", default=[], help="KEY=VALUE override of the scene")
    parser.add_argument("--last", type=int, default=40, help="with --scene: the steps printed")
    args = parser.parse_args(argv)
    if args.scene:
        rows = scene_rows(args.scene, args.set, args.last)
        if MPI.COMM_WORLD.rank == 0:
            print("\n".join(rows))
        return 0
    rows = ["| solid.displacement | δt | velocity's in-cell departure (m/s) | largest velocity (m/s) | "
            "displacement's in-cell departure (m) |", "|---|---|---|---|---|"]
    for displacement in ("quadratic", "linear"):
        for dt in args.dt:
            r = run(displacement, dt, args.t_end)
            rows.append(f"| {displacement} | {dt:g} | {r['velocity']:.3g} | {r['largest velocity']:.3g} | "
                        f"{r['displacement']:.2g} |")
    if MPI.COMM_WORLD.rank == 0:
        print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
