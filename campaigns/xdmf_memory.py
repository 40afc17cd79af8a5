"""Peak memory per rank reading a 3D mesh from its .msh (rank 0 reads it whole, then distributes it) and from its
XDMF/HDF5 conversion (every rank reads its share), and a steady solve from the .xdmf (docs/perf_scale_3d.md,
"Meshes larger than rank 0 holds"). Run by hand, not a test:

    python campaigns/xdmf_memory.py --levels 1 2 --solve-level 0 --out runs/xdmf_memory

For each level of the built-in schaefer_turek_3d: ``cosserat-fsi mesh --format xdmf`` (one process), then on 2
ranks ``runner.load_mesh`` of the built-in scene (the .msh) and of the .xdmf scene, each in a fresh process, and
the peak RSS (getrusage) of each rank after the read. ``--solve-level``: ``cosserat-fsi run`` of the steady
3D-1Z flow from that level's .xdmf on 2 ranks with ``solver.type: auto`` (summary.json's peak per rank).
Prints a JSON line per measurement and writes them to OUT/memory.json.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BUILTIN = REPO / "configs" / "schaefer_turek_3d1z.yaml"
XDMF_SCENE = """geometry: {{name: file, path: {path}}}
fluid: {{rho: 1.0, mu: 1.0e-3}}
boundaries:
  inlet: {{type: velocity, value: ['16*0.45*y*z*(0.41 - y)*(0.41 - z)/0.41**4', 0, 0]}}
  outlet: {{type: do_nothing}}
  walls: {{type: no_slip}}
  cylinder: {{type: no_slip}}
observables: {{forces: [cylinder]}}
solver: {{type: auto}}
time: {{scheme: steady}}
output: {{progress: false, fields: false}}
"""


def launcher() -> list[str]:
    sys.path.insert(0, str(REPO))
    from cosserat_fsi.app.cases import mpi_launcher

    return mpi_launcher(2)


def load_only(scene_path: str, sets: list[str]) -> None:
    """Under mpirun: read the scene's mesh as ``run`` does; rank 0 prints the peak RSS of every rank (MiB)."""
    from mpi4py import MPI

    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import load_scene

    comm = MPI.COMM_WORLD
    scene = load_scene(scene_path, sets)
    mesh = load_mesh(scene, comm)[0]
    peaks = comm.gather(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
    cells = mesh.topology.index_map(mesh.topology.dim).size_global
    if comm.rank == 0:
        print(json.dumps({"cells": cells, "peak_rss_mib_per_rank": [round(p, 1) for p in peaks]}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--solve-level", type=int, default=None)
    parser.add_argument("--out", default="runs/xdmf_memory")
    parser.add_argument("--load", nargs="+", help=argparse.SUPPRESS)  # the child: SCENE [KEY=VALUE ...]
    args = parser.parse_args()
    if args.load:
        return load_only(args.load[0], args.load[1:])
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p),
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    cli = [sys.executable, "-m", "cosserat_fsi"]
    results = []
    for level in sorted(set(args.levels) | ({args.solve_level} - {None})):
        subprocess.run([*cli, "mesh", BUILTIN, "--set", f"geometry.level={level}", "--format", "xdmf", "--out", out],
                       check=True, env=env)
        scene = out / f"xdmf-L{level}.yaml"
        scene.write_text(XDMF_SCENE.format(path=out / f"schaefer_turek_3d-L{level}.xdmf"))
        if level in args.levels:
            for kind, argv in (("msh", [BUILTIN, f"geometry.level={level}"]), ("xdmf", [scene])):
                done = subprocess.run([*launcher(), sys.executable, __file__, "--load", *map(str, argv)], check=True,
                                      env=env, capture_output=True, text=True)
                row = {"level": level, "read": kind, **json.loads(done.stdout.strip().splitlines()[-1])}
                print(json.dumps(row), flush=True)
                results.append(row)
        if level == args.solve_level:
            run = out / f"solve-L{level}"
            subprocess.run([*launcher(), *cli, "run", scene, "--out", run, "--overwrite"], check=True, env=env)
            summary = json.loads((run / "summary.json").read_text())
            solver = summary.get("linear_solver", {}).get("type")
            row = {"level": level, "read": "xdmf", "solve": "steady, solver.type auto",
                   "dofs": summary["dofs"]["total"],
                   "wall_s": round(summary["wall_time"]["total"], 1), "linear_solver": solver,
                   "peak_rss_mib_per_rank": [round(p, 1) for p in summary["memory"]["peak_rss_mib_per_rank"]]}
            print(json.dumps(row), flush=True)
            results.append(row)
    (out / "memory.json").write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
