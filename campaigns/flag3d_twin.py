"""The built-in 3D flag FSI scene and its user-file twin: the numbers of docs/validation_3d.md, "3D FSI scene as a
user's file".

configs/turek_hron_3d_fsi.yaml (geometry turek_hron_3d, level 0: conditions and observables of the preset)
against tests/data/user_scene/turek_hron_3d_fsi.yaml: the same geometry written by hand as a user's .geo
(tests/data/user_scene/turek_hron_3d.geo, meshed by gmsh into the built-in mesh, node for node), volumes
``water`` and ``flag`` mapped with ``geometry.cells``, the conditions in a ``boundaries`` section (the duct
profile and its ramp as an expression of y, z, t) and the observables named (forces on the cylinder and the
wetted flag, the tip A as a solid point, a probe, the outflow's flow rate). Both run in this process for the
same steps; every column they share (the twin's ``flow_rate_outflow`` is the preset's ``flow_rate``) is
compared by its maximum relative difference over the run, max_t |a − b| / max_t |a|.

    python campaigns/flag3d_twin.py              # 0.1 s = 20 steps of each (about 2-3 min on one core)
    python campaigns/flag3d_twin.py --steps 4    # fewer steps
    python campaigns/flag3d_twin.py --preset-inflow   # the twin's inflow as the preset's own expression text
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))
sys.path.insert(0, str(ROOT))

PRESET = ROOT / "configs" / "turek_hron_3d_fsi.yaml"
TWIN = ROOT / "tests" / "data" / "user_scene" / "turek_hron_3d_fsi.yaml"
RENAMED = {"flow_rate_outflow": "flow_rate"}
"""The twin's column -> the preset's column of the same quantity."""
SAME_SECTIONS = ("fluid", "micropolar", "solid", "time", "output", "solver")
"""The sections the two scenes must have equal (the rest is the geometry and what the preset derives from it)."""


def scenes(steps: int, dt: float | None = None, preset_inflow: bool = False):
    """The preset on level 0 and its twin, both ending after ``steps`` steps (``dt``: another step size;
    ``preset_inflow``: the twin's inflow given as the preset's own expression, the same text)."""
    from cosserat_fsi.config import load_scene, validate_scene

    overrides = ["geometry.level=0"] + ([f"time.dt={dt!r}"] if dt is not None else [])
    preset = load_scene(PRESET, overrides)
    t_end = steps * preset.time.dt
    preset = load_scene(PRESET, overrides + [f"time.t_end={t_end!r}"])
    twin = load_scene(TWIN, overrides[1:] + [f"time.t_end={t_end!r}"])
    a, b = preset.model_dump(mode="json"), twin.model_dump(mode="json")
    differ = [key for key in SAME_SECTIONS if a.get(key) != b.get(key)]
    if differ:
        raise SystemExit(f"{TWIN.name} and {PRESET.name} differ in {', '.join(differ)}")
    if preset_inflow:
        b["boundaries"]["inflow"] = preset.conditions()["inlet"].model_dump(mode="json")
        twin = validate_scene(b)
    return preset, twin


def series(scene, steps: int) -> dict[str, np.ndarray]:
    """The observables of ``scene`` after each of ``steps`` steps, by column."""
    from mpi4py import MPI

    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.observables import Observables
    from cosserat_fsi.simulation import Simulation

    mesh, ct, ft, _ = load_mesh(scene, MPI.COMM_WORLD)
    sim = Simulation(scene, mesh, ct, ft, MPI.COMM_WORLD)
    obs = Observables(sim)
    rows = []
    sim.run(steps, observers=[lambda sim: rows.append(obs.evaluate())])
    return {RENAMED.get(k, k): np.array([r[k] for r in rows]) for k in rows[0]}


def differences(a: dict, b: dict) -> dict[str, tuple[float, float]]:
    """{column: (max_t |a|, max_t |a − b| / max_t |a|)} over the columns of both series (0/0 is 0)."""
    out = {}
    for key in sorted(set(a) & set(b)):
        scale = float(np.abs(a[key]).max())
        diff = float(np.abs(a[key] - b[key]).max())
        out[key] = (scale, diff / scale if scale > 0 else diff)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=20, help="steps of each run (default 20: 0.1 s at 5 ms)")
    parser.add_argument("--preset-inflow", action="store_true",
                        help="the twin's inflow as the preset's expression text (the rest of the difference)")
    args = parser.parse_args(argv)
    preset, twin = scenes(args.steps, preset_inflow=args.preset_inflow)
    started = time.perf_counter()
    a = series(preset, args.steps)
    middle = time.perf_counter()
    b = series(twin, args.steps)
    done = time.perf_counter()
    print(f"{args.steps} steps to t = {args.steps * preset.time.dt:g} s: preset {middle - started:.0f} s, "
          f"twin {done - middle:.0f} s (wall)")
    print(f"only in the preset: {', '.join(sorted(set(a) - set(b))) or '-'}; "
          f"only in the twin: {', '.join(sorted(set(b) - set(a))) or '-'}")
    print("| column | max abs (preset) | max relative difference |")
    print("|---|---|---|")
    worst = 0.0
    for key, (scale, rel) in differences(a, b).items():
        print(f"| {key} | {scale:.4g} | {rel:.1e} |")
        worst = max(worst, rel)
    print(f"worst: {worst:.1e}")
    return 0 if worst <= 1e-6 else 1


if __name__ == "__main__":
    sys.exit(main())
