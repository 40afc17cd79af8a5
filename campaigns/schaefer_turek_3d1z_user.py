"""Schäfer–Turek 3D-1Z from the user's .geo files (examples/schaefer_turek_3d1z) at a ladder of meshes: the
numbers of docs/validation_3d.md, "3D-1Z as a user's .geo". Run by hand, not a test:

    python campaigns/schaefer_turek_3d1z_user.py --out runs/st3d_user --geo duct_blocks.geo \
        --size "" --size "n_q=24"                     # each --size: the .geo's parameters ("": as shipped)
    python campaigns/schaefer_turek_3d1z_user.py --out runs/st3d_user --geo duct.geo --size "h_cyl=0.004"
    python campaigns/schaefer_turek_3d1z_user.py --out runs/st3d_user --table   # the table of what ran

``--geo``: duct.geo (a graded unstructured mesh) or duct_blocks.geo (block-structured, extruded in layers).
Each size is a set of the .geo's DefineConstant parameters (the rest keep its values): the script writes
OUT/geo/NAME.geo (the parameters, then ``Include "GEO"``, a copy of the example's) and runs
``cosserat-fsi run examples/schaefer_turek_3d1z/duct.yaml --set geometry.path=OUT/geo/NAME.geo`` on
``--ranks`` ranks (default 2) into OUT/NAME, a fresh process each, with its wall time and its CPU time (user +
system of the launcher and every rank, from the kernel's accounting of the finished children). Then c_D, c_L
and Δp (examples/schaefer_turek_3d1z/compare.py) against the reference, the cells, unknowns, Newton and FGMRES
iterations and the peak memory per rank (summary.json). Every row is appended to OUT/results.json; ``--table``
prints the markdown table of docs/validation_3d.md from it. The wall time includes meshing (gmsh on rank 0) unless
the mesh is in the cache ($COSSERAT_FSI_MESH_CACHE; the column ``meshed`` says which); the load average at the
start and end of each run is recorded (the machine may be shared).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "schaefer_turek_3d1z"
sys.path.insert(0, str(EXAMPLE))
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))

from compare import coefficients, errors, reference  # noqa: E402 (the example's own script)

from cosserat_fsi.app.cases import mpi_launcher  # noqa: E402

PARAMETER = re.compile(r"^([A-Za-z_][A-Za-z_0-9]*)=([0-9.eE+-]+)$")
TOLERANCE = 0.5  # percent: the target for c_D, c_L and dp


def parse_size(spec: str) -> dict[str, float]:
    """``"h_cyl=0.004 h_far=0.05"`` -> {name: value}."""
    out = {}
    for item in spec.split():
        m = PARAMETER.match(item)
        if not m:
            raise SystemExit(f"--size: {item!r} is not NAME=NUMBER")
        out[m.group(1)] = float(m.group(2))
    return out


def size_name(params: dict[str, float]) -> str:
    return "-".join(f"{k}{v:g}" for k, v in params.items()) or "default"


def write_geo(folder: Path, base: str, params: dict[str, float]) -> Path:
    """OUT/geo/STEM-NAME.geo: the parameters, then Include the copy of the example's ``base`` beside it."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(EXAMPLE / base, folder / base)
    path = folder / f"{Path(base).stem}-{size_name(params)}.geo"
    lines = [f"{k} = {v!r};" for k, v in params.items()]
    path.write_text("\n".join(lines + [f'Include "{base}";', ""]))
    return path


def cells_of(run: Path) -> int | None:
    """The cell count of the run's mesh (run.log's ``mesh ...: N vertices, M cells``)."""
    m = re.search(r"INFO cosserat_fsi: mesh .*?: [\d,]+ vertices, ([\d,]+) cells", (run / "run.log").read_text())
    return int(m.group(1).replace(",", "")) if m else None


def run_one(base: str, params: dict[str, float], out: Path, ranks: int, sets: list[str]) -> dict:
    geo = write_geo(out / "geo", base, params)
    run = out / geo.stem
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p),
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    launch = mpi_launcher(ranks) if ranks > 1 else []
    argv = [*launch, sys.executable, "-m", "cosserat_fsi", "run", str(EXAMPLE / "duct.yaml"), "--out",
            str(run), "--overwrite", "--no-progress", "--set", f"geometry.path={geo}"]
    for item in sets:
        argv += ["--set", item]
    cache = Path(os.environ["COSSERAT_FSI_MESH_CACHE"])
    cached = set(cache.glob("*.msh")) if cache.is_dir() else set()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    done = subprocess.run(argv, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    (out / f"{run.name}.stdout").write_text(done.stdout + done.stderr)
    row = {"geo": base, "size": params, "name": run.name, "ranks": ranks, "sets": sets, "returncode": done.returncode,
           "wall_s": round(wall, 1), "cpu_s": round(cpu, 1), "load_start": round(load, 2),
           "load_end": round(os.getloadavg()[0], 2)}
    if done.returncode != 0 or not (run / "summary.json").exists():
        row["error"] = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no output"]
        return row
    summary = json.loads((run / "summary.json").read_text())
    values = coefficients(run)
    solver = summary.get("linear_solver", {})
    row.update({
        "meshed": bool(set(cache.glob("*.msh")) - cached),
        "vertices": summary["mesh"]["vertices"], "cells": cells_of(run), "unknowns": summary["dofs"]["total"],
        **{k: values[k] for k in ("c_D", "c_L", "dp", "c_D_surface", "c_L_surface")},
        "errors_percent": errors(values, reference()),
        "newton": summary["newton"]["iterations"], "solver": solver.get("type"),
        "krylov_mean": solver.get("krylov_iterations", {}).get("mean"),
        "run_wall_s": round(summary["wall_time"]["total"], 1),
        "peak_rss_mib_per_rank": [round(p) for p in summary["memory"]["peak_rss_mib_per_rank"]],
    })
    row["within"] = all(abs(e) <= TOLERANCE for e in row["errors_percent"].values())
    return row


def table(rows: list[dict]) -> str:
    head = ("| mesh | cells | unknowns | c_D | err | c_L | err | Δp | err | within 0.5 % | Newton | "
            "FGMRES / solve | wall | CPU | peak per rank | load |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        size = f"{r.get('geo', 'duct.geo')}: " + (", ".join(f"{k} {v:g}" for k, v in r["size"].items()) or "as shipped")
        if "error" in r:
            lines.append(f"| {size} | | | failed: {r['error'][0]} |" + " |" * 12)
            continue
        e = r["errors_percent"]
        peak = " / ".join(f"{p / 1024:.2f}" for p in r["peak_rss_mib_per_rank"])
        fgmres = f"{r['krylov_mean']:.1f}" if r.get("krylov_mean") else "–"
        lines.append(f"| {size} | {r['cells']:,} | {r['unknowns']:,} | {r['c_D']:.5f} | {e['c_D']:+.3f} % | "
                     f"{r['c_L']:.6f} | {e['c_L']:+.2f} % | {r['dp']:.6f} | {e['dp']:+.3f} % | "
                     f"{'yes' if r['within'] else 'no'} | {r['newton']} | {fgmres} | {r['wall_s']:.0f} s | "
                     f"{r['cpu_s']:.0f} s | {peak} GB | {r['load_start']:.1f}–{r['load_end']:.1f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="runs/st3d_user")
    parser.add_argument("--geo", default="duct_blocks.geo", choices=["duct.geo", "duct_blocks.geo"])
    parser.add_argument("--size", action="append", default=[], help='the .geo\'s parameters, "n_q=24 n_r=10"')
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], help="a scene override for every run, KEY=VALUE")
    parser.add_argument("--table", action="store_true", help="print the table of OUT/results.json and stop")
    args = parser.parse_args()
    out = Path(args.out).resolve()
    results = out / "results.json"
    rows = json.loads(results.read_text()) if results.exists() else []
    if args.table:
        print(table(rows))
        return
    out.mkdir(parents=True, exist_ok=True)
    for spec in args.size or [""]:
        row = run_one(args.geo, parse_size(spec), out, args.ranks, args.set)
        print(json.dumps(row), flush=True)
        rows.append(row)
        results.write_text(json.dumps(rows, indent=1) + "\n")
    print(table(rows))


if __name__ == "__main__":
    main()
