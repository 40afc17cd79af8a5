"""How far each mesh motion carries a bent flag (a measurement script, not a test).

    python campaigns/mesh_motion.py [--levels seed 1] [--step 0.0025] [--max 0.15] [--json FILE]
    mpirun -n 2 python campaigns/mesh_motion.py ...

The Turek–Hron flag (solid cells of the ``turek_hron`` geometry, ``flag: solid``) is bent as a cantilever in
pure bending: its centreline y = 0.2 becomes a circular arc from the clamp, of the curvature that puts the
centreline's tip ``delta`` higher (δ = (1 − cos κL)/κ). Every solid vertex gets that displacement exactly; the
fluid vertices follow the extension of each mesh motion, solved once per δ from the reference mesh (the total
formulation the runs use, so the result does not depend on the path). For δ = 0, step, …, max it records the
minimum normalised cell quality 4√3·|K|/Σ|e|² and reports, per method: the δ at which it first drops below
0.1 (and 0.2), the δ at which the run would stop (a cell below 1e-3 of its reference area, the check of
mesh/motion.py) and where a cell inverts; plus the setup (assembly + factorisation) and the cost of one
extension (mult + solve with the kept factorisation).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))

CLAMP_X = 0.2 + np.sqrt(0.05 ** 2 - 0.01 ** 2)  # where the flag leaves the cylinder
FLAG_LENGTH, CENTRE_Y = 0.6 - CLAMP_X, 0.2
METHODS = {  # label -> MeshMotion keyword arguments
    "harmonic (1/|K|, today's)": {"method": "harmonic"},
    "elastic ν=0, χ=0": {"method": "elastic", "stiffness_exponent": 0.0, "poisson_ratio": 0.0},
    "elastic ν=0, χ=0.5": {"method": "elastic", "stiffness_exponent": 0.5, "poisson_ratio": 0.0},
    "elastic ν=0, χ=1": {"method": "elastic", "stiffness_exponent": 1.0, "poisson_ratio": 0.0},
    "elastic ν=0, χ=2": {"method": "elastic", "stiffness_exponent": 2.0, "poisson_ratio": 0.0},
    "elastic ν=−0.2, χ=1": {"method": "elastic", "stiffness_exponent": 1.0, "poisson_ratio": -0.2},
    "elastic ν=−0.2, χ=0.5": {"method": "elastic", "stiffness_exponent": 0.5, "poisson_ratio": -0.2},
    "elastic ν=0.3, χ=1": {"method": "elastic", "stiffness_exponent": 1.0, "poisson_ratio": 0.3},
    "biharmonic χ=0": {"method": "biharmonic", "stiffness_exponent": 0.0},
    "biharmonic χ=0.5": {"method": "biharmonic", "stiffness_exponent": 0.5},
    "biharmonic χ=1": {"method": "biharmonic", "stiffness_exponent": 1.0},
}


def curvature(delta: float) -> float:
    """κ with (1 − cos κL)/κ = δ (bisection; δ below the maximum ≈ 0.72 L)."""
    if delta <= 0:
        return 0.0
    lo, hi = 1e-12, 2.3 / FLAG_LENGTH
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if (1 - np.cos(mid * FLAG_LENGTH)) / mid < delta else (lo, mid)
    return 0.5 * (lo + hi)


def bending(points: np.ndarray, delta: float) -> np.ndarray:
    """Displacement (n, 2) of the flag's points (n, 2) in pure bending with centreline tip deflection δ."""
    kappa = curvature(delta)
    s, eta = np.maximum(points[:, 0] - CLAMP_X, 0.0), points[:, 1] - CENTRE_Y
    if kappa == 0.0:
        return np.zeros_like(points)
    dx = (1 - kappa * eta) * np.sin(kappa * s) / kappa - s
    dy = (1 - (1 - kappa * eta) * np.cos(kappa * s)) / kappa - eta
    return np.column_stack([dx, dy])


def sweep(level, options: dict, deltas: np.ndarray, comm) -> dict:
    from mpi4py import MPI

    from cosserat_fsi import compat
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import validate_scene
    from cosserat_fsi.mesh.motion import MeshMotion

    scene = validate_scene({"geometry": {"name": "turek_hron", "level": level, "flag": "solid"},
                            "fluid": {"rho": 1.0, "mu": 1.0}, "solid": {"rho": 1.0, "mu_s": 1.0},
                            "inflow": {"u_mean": 1.0}, "time": {"dt": 0.1, "t_end": 1.0}})
    mesh, ct, _, _ = load_mesh(scene, comm)
    comm.Barrier()
    t0 = time.perf_counter()
    motion = MeshMotion(mesh, ct, comm, **options)
    setup = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    points = np.zeros((len(motion.displacement.x.array) // 2, 2))
    points[motion.node_dof[: len(motion.X0)]] = motion.X0
    cells = comm.allreduce(compat.num_owned_cells(mesh), op=MPI.SUM)
    rows, costs = [], []
    for delta in deltas:
        solid = bending(points, delta).ravel()
        comm.Barrier()
        t0 = time.perf_counter()
        total = motion.extend(solid)
        costs.append(comm.allreduce(time.perf_counter() - t0, op=MPI.MAX))
        x = mesh.geometry.x
        x[:, :2] = motion.X0 + total.reshape(-1, 2)[motion.node_dof]
        quality = motion.quality()
        area_ratio = motion._areas() / motion.ref_area
        x[:, :2] = motion.X0
        rows.append((float(delta), comm.allreduce(float(quality.min()), op=MPI.MIN),
                     comm.allreduce(float(area_ratio.min()), op=MPI.MIN)))

    def first(test):
        return next((d for d, q, a in rows if test(q, a)), None)

    return {"level": str(level), "cells": cells, "options": options, "setup_s": setup,
            "extension_s": float(np.median(costs)), "rows": rows,
            "below_0.2": first(lambda q, a: q < 0.2), "below_0.1": first(lambda q, a: q < 0.1),
            "stop": first(lambda q, a: a < 1e-3), "inverted": first(lambda q, a: q <= 0)}


def table(results: list[dict]) -> str:
    def cm(v):
        return "> max" if v is None else f"{100 * v:.2f}"

    lines = ["| mesh (cells) | method | tip δ at q_min < 0.2 (cm) | < 0.1 (cm) | run stops (area < 1e-3) (cm) | "
             "inverted (cm) | q_min at 5 / 10 / 15 cm | setup (s) | per step (ms) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        q = {round(d, 6): qm for d, qm, _ in r["rows"]}
        at = " / ".join(f"{q[c]:.3f}" if c in q else "–" for c in (0.05, 0.10, 0.15))
        lines.append(f"| L{r['level']} ({r['cells']}) | {r['label']} | {cm(r['below_0.2'])} | {cm(r['below_0.1'])} | "
                     f"{cm(r['stop'])} | {cm(r['inverted'])} | {at} | {r['setup_s']:.2f} | "
                     f"{1e3 * r['extension_s']:.1f} |")
    return "\n".join(lines)


def main() -> None:
    from mpi4py import MPI

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", nargs="+", default=["seed", "1"])
    parser.add_argument("--step", type=float, default=0.0025)
    parser.add_argument("--max", type=float, default=0.15)
    parser.add_argument("--methods", nargs="+", default=list(METHODS), help="labels of METHODS")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    deltas = np.round(np.arange(0.0, args.max + 1e-9, args.step), 6)
    results = []
    for level in args.levels:
        level = level if level == "seed" else int(level)
        for label in args.methods:
            result = sweep(level, METHODS[label], deltas, comm)
            result["label"] = label
            results.append(result)
            if comm.rank == 0:
                print(table([result]).splitlines()[-1], flush=True)
    if comm.rank == 0:
        print(table(results))
        if args.json:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps(results, indent=1, ensure_ascii=False))


if __name__ == "__main__":
    main()
