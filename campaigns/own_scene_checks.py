"""A user's own scene against closed forms, through the command line as a user runs it: the numbers of
docs/validation.md, "Your own scene".

* Micropolar Couette flow (a moving top wall: ``velocity`` + ``micro_rotation: {value: EXPR}``) and
  micropolar Poiseuille flow driven by two ``pressure`` boundaries, on tests/data/user_scene/strip.geo
  (2 × 1, μ = μ_r = 1, λ₁ = 0.5), sampled by ``observables.lines`` across x = 1 (41 points): the relative
  max errors of u and ω against cosserat_fsi/exact.py on levels 0, 1, 2.
* Mass: a Poiseuille inflow of flux 1 into a do-nothing outlet for μ from 1e-6 to 1e10, steady and with
  3 steps of characteristics1: |outflow − 1| (the flow_rate column at the outlet).

    python campaigns/own_scene_checks.py        # prints the tables (about a minute on one core)
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))
sys.path.insert(0, str(ROOT))

from cosserat_fsi.exact import MicropolarCouette, MicropolarPoiseuille  # noqa: E402

STRIP = ROOT / "tests" / "data" / "user_scene" / "strip.geo"
CHANNEL = ROOT / "tests" / "data" / "user_scene" / "channel.geo"
MU, MU_R, LAMBDA1 = 1.0, 1.0, 0.5
COUETTE = ("{top: {type: velocity, value: [1, 0], micro_rotation: {value: 0.3}}, bottom: {type: no_slip, "
           "micro_rotation: zero}, inlet: {type: pressure, value: 0}, outlet: {type: do_nothing}}")
POISEUILLE = ("{inlet: {type: pressure, value: 2}, outlet: {type: pressure, value: 0}, bottom: {type: no_slip, "
              "micro_rotation: zero}, top: {type: no_slip, micro_rotation: zero}}")


def run(scene: str, folder: Path) -> Path:
    """``cosserat-fsi run`` of the scene text in ``folder``; the output folder."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "scene.yaml").write_text(scene)
    out = folder / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-m", "cosserat_fsi", "run", folder / "scene.yaml", "--out", out],
                          capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr)
    return out


def line(out: Path, name: str = "across") -> dict:
    with open(out / f"line_{name}.csv") as f:
        header = f.readline().strip().split(",")
    rows = np.loadtxt(out / f"line_{name}.csv", delimiter=",", skiprows=1, ndmin=2)
    return {key: rows[:, i] for i, key in enumerate(header)}


def closed_forms(tmp: Path) -> None:
    print("| level | Couette u | Couette ω | Poiseuille u | Poiseuille ω |")
    print("|---|---|---|---|---|")
    for level in (0, 1, 2):
        errors = []
        for name, boundaries in (("couette", COUETTE), ("poiseuille", POISEUILLE)):
            scene = (f"geometry: {{name: file, path: {STRIP}, level: {level}}}\n"
                     f"fluid: {{rho: 1.0, mu: {MU}}}\nmicropolar: {{mu_r: {MU_R}, lambda1: {LAMBDA1}}}\n"
                     f"time: {{scheme: steady}}\nboundaries: {boundaries}\n"
                     "observables: {lines: {across: {from: [1.0, 0.0], to: [1.0, 1.0], points: 41}}}\n"
                     "output: {progress: false, fields: false}\n")
            data = line(run(scene, tmp / f"{name}{level}"))
            y = data["y"]
            if name == "couette":
                u, w = MicropolarCouette(1.0, 0.0, 0.3, MU, MU_R, LAMBDA1).profiles(y)
            else:
                u, w = MicropolarPoiseuille(1.0, 0.5, MU, MU_R, LAMBDA1, 2.0).profiles(np.vstack([np.ones_like(y), y]))
            errors += [np.abs(data["u"] - u).max() / np.abs(u).max(), np.abs(data["omega"] - w).max() / np.abs(w).max()]
        print(f"| {level} | " + " | ".join(f"{e:.1e}" for e in errors) + " |")


def mass(tmp: Path) -> None:
    print("\n| μ | steady: outflow − 1 | characteristics1, 3 steps: max |outflow − 1| |")
    print("|---|---|---|")
    for mu in (1e-6, 1e-3, 1.0, 1e3, 1e6, 1e10):
        cells = []
        for time in ("{scheme: steady}", "{scheme: characteristics1, dt: 0.1, t_end: 0.3}"):
            scene = (f"geometry: {{name: file, path: {CHANNEL}}}\nfluid: {{rho: 1.0, mu: {mu}}}\ntime: {time}\n"
                     "boundaries: {inlet: {type: velocity, value: ['6*y*(1 - y)', 0]}, outlet: {type: do_nothing}, "
                     "bottom: {type: no_slip}, top: {type: no_slip}}\noutput: {progress: false, fields: false}\n")
            out = run(scene, tmp / f"mass{mu:g}{len(cells)}")
            series = np.genfromtxt(out / "timeseries.csv", delimiter=",", names=True)
            cells.append(float(np.max(np.abs(np.atleast_1d(series["flow_rate"]) - 1.0))))
        print(f"| {mu:g} | {cells[0]:.1e} | {cells[1]:.1e} |")


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        closed_forms(Path(tmp))
        mass(Path(tmp))
