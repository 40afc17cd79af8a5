"""The cost of a step in the periodic flow under solver settings that leave the solution unchanged (benchmark
script, not a test; docs/fsi3_table.md, "Cost").

    python campaigns/step_cost_variants.py RUN --until 8.4 --out /tmp/variants \\
        --variant lu solver.reuse_factorization=false --variant reuse solver.reuse_factorization=true

RUN is a finished run with a checkpoint (e.g. a shipped FSI3 run to t = 8). Each variant is a copy of RUN
continued with ``--restart`` to ``--until`` with its ``--set`` values: the copy's checkpoint is re-keyed to the
variant's scene (a restart refuses another scene; the solver settings change how each step is solved, not
what is solved: the solutions agree to the Krylov tolerance). Two variants run at a time, one per core, so
each pair shares the machine's load. Printed per variant: steps, rejected steps, factorisations, Krylov
iterations per solve, and the wall time of each phase (summary.json's ``wall_time``).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "campaigns"))
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))


def prepare(run: Path, folder: Path, sets: list[str]) -> None:
    """Copy ``run`` to ``folder`` and key its checkpoint to the scene with ``sets``."""
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.io.checkpoint import scene_fingerprint

    shutil.rmtree(folder, ignore_errors=True)
    shutil.copytree(run, folder)
    (folder / "exit_code").unlink(missing_ok=True)
    meta_path = folder / "checkpoint" / "meta.json"
    meta = json.loads(meta_path.read_text())
    meta["fingerprint"] = scene_fingerprint(load_scene(folder / "config.yaml", sets))
    meta_path.write_text(json.dumps(meta, indent=2))


def command(folder: Path, sets: list[str], until: float) -> list[str]:
    extra = [arg for s in sets for arg in ("--set", s)]
    return [sys.executable, "-m", "cosserat_fsi", "run", str(folder / "config.yaml"), "--restart", str(folder),
            "--set", f"time.t_end={until}", *extra, "--no-progress"]


def row(name: str, folder: Path, start_step: int) -> str:
    s = json.loads((folder / "summary.json").read_text())
    solver, wall = s["linear_solver"], s["wall_time"]
    phases = wall["phases"]
    krylov = (solver.get("krylov_iterations") or {}).get("mean")
    return (f"| {name} | {s['time']['steps'] - start_step} | {solver['factorisations']} | "
            f"{'–' if krylov is None else f'{krylov:.1f}'} | {phases.get('solve', 0):.1f} | "
            f"{phases.get('assemble_matrix', 0):.1f} | {wall['total']:.1f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--until", type=float, required=True, help="time.t_end of the continued runs")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--variant", nargs="+", action="append", required=True, metavar=("NAME", "KEY=VALUE"))
    args = parser.parse_args()
    start_step = json.loads((args.run / "checkpoint" / "meta.json").read_text())["step"]
    variants = [(v[0], v[1:]) for v in args.variant]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    for i in range(0, len(variants), 2):  # side by side, one per core
        procs = []
        for name, sets in variants[i:i + 2]:
            folder = args.out / name
            prepare(args.run, folder, sets)
            log = open(args.out / f"{name}.log", "w")
            procs.append((subprocess.Popen(command(folder, sets, args.until), env=env, stdout=log,
                                           stderr=subprocess.STDOUT), log))
        for proc, log in procs:
            proc.wait()
            log.close()
    print("| variant | steps | factorisations | Krylov its / solve | solve (s) | assemble matrix (s) | wall (s) |")
    print("|---|---|---|---|---|---|---|")
    for name, _ in variants:
        print(row(name, args.out / name, start_step))


if __name__ == "__main__":
    main()
