"""A thin clamped strip in a light fluid: its first bending frequency against Euler–Bernoulli theory.

The strip [0, 1] × [−h/2, h/2] (h = 0.05, L/h = 20) is clamped to the left wall of a 2 × 2 box of fluid
1000× lighter than the solid (ρ_f = 1, μ_f = 10⁻³; the right side an outlet, the others no-slip walls), its
mesh structured with ``n`` cells across and 40 along (the fluid's mesh is the same for every ``n``). At t = 0
a small weight (g = 0.3 m/s²) is switched on: the strip swings about its static deflection (1 % of its
length) in its first mode. Euler–Bernoulli with the law's plane-strain modulus E' = E/(1 − ν²):
f₁ = 1.8751²/(2π) √(E' h² / (12 ρ_s L⁴)). What lowers the computed frequency besides the discretisation: the
fluid's added mass (≈ ρ_f π L²/4 over ρ_s h L = 1.6 %, i.e. ≈ −0.8 % in frequency) and shear and rotary
inertia (Timoshenko, ≈ −0.3 % at L/h = 20).

    python campaigns/thin_strip.py [--cells 2 4 8] [--law saint_venant_kirchhoff]   # numbers for docs/validation.md
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))

LENGTH, THICKNESS, ALONG = 1.0, 0.05, 40
RHO_S, E, NU = 1000.0, 1.4e7, 0.4
RHO_F, MU_F, GRAVITY = 1.0, 1.0e-3, 0.3

GEO = """// a thin strip clamped to the left wall of a 2 x 2 box (campaigns/thin_strip.py)
L = {length}; h = {thickness}; n = {across}; m = {along};
h_far = 0.2; h_strip = L / m;
Point(1) = {{0, -1, 0, h_far}}; Point(2) = {{2, -1, 0, h_far}}; Point(3) = {{2, 1, 0, h_far}};
Point(4) = {{0, 1, 0, h_far}}; Point(5) = {{0, h/2, 0, h_strip}}; Point(6) = {{0, -h/2, 0, h_strip}};
Point(7) = {{L, -h/2, 0, h_strip}}; Point(8) = {{L, h/2, 0, h_strip}};
Line(1) = {{1, 2}}; Line(2) = {{2, 3}}; Line(3) = {{3, 4}}; Line(4) = {{4, 5}}; Line(5) = {{5, 6}};
Line(6) = {{6, 1}}; Line(7) = {{6, 7}}; Line(8) = {{7, 8}}; Line(9) = {{8, 5}};
Curve Loop(1) = {{1, 2, 3, 4, -9, -8, -7, 6}}; Plane Surface(1) = {{1}};
Curve Loop(2) = {{7, 8, 9, 5}}; Plane Surface(2) = {{2}};
Transfinite Curve{{7, 9}} = m + 1; Transfinite Curve{{5, 8}} = n + 1;
Transfinite Surface{{2}};
Field[1] = Distance; Field[1].CurvesList = {{7, 8, 9}};
Field[2] = Threshold; Field[2].InField = 1; Field[2].SizeMin = h_strip; Field[2].SizeMax = h_far;
Field[2].DistMin = 0.02; Field[2].DistMax = 0.8;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Physical Surface("fluid") = {{1}};
Physical Surface("solid") = {{2}};
Physical Curve("walls") = {{1, 3, 4, 6}};
Physical Curve("outlet") = {{2}};
Physical Curve("clamp") = {{5}};
"""


def plane_strain_modulus(E: float = E, nu: float = NU) -> float:
    return E / (1.0 - nu ** 2)


def beam_frequency(E: float = E, nu: float = NU) -> float:
    """Euler–Bernoulli first frequency (Hz) of the clamped strip with the plane-strain modulus."""
    return 1.8751 ** 2 / (2.0 * math.pi) * math.sqrt(plane_strain_modulus(E, nu) * THICKNESS ** 2
                                                     / (12.0 * RHO_S * LENGTH ** 4))


def write_geo(folder: Path, across: int) -> Path:
    path = Path(folder) / f"thin_strip_n{across}.geo"
    path.write_text(GEO.format(length=LENGTH, thickness=THICKNESS, across=across, along=ALONG), encoding="utf-8")
    return path


def scene(geo: Path, law: str = "saint_venant_kirchhoff", dt: float = 0.01, t_end: float = 3.0) -> dict:
    """The scene (a dict for ``validate_scene``) of the strip meshed in ``geo``."""
    solid = {"rho": RHO_S, "gravity": GRAVITY}
    if law == "mooney_rivlin_incompressible":  # the same bending stiffness 4μ = E'
        solid.update(law=law, mu_s=plane_strain_modulus() / 4.0)
    else:
        solid.update(law=law, E=E, nu=NU)
    return {"geometry": {"name": "file", "path": str(geo)},
            "fluid": {"rho": RHO_F, "mu": MU_F},
            "solid": solid,
            "boundaries": {"walls": {"type": "no_slip"}, "clamp": {"type": "no_slip"},
                           "outlet": {"type": "do_nothing"}},
            "observables": {"solid_points": {"tip": [LENGTH, 0.0]}},
            "time": {"scheme": "ale_bdf2", "dt": dt, "t_end": t_end},
            "output": {"fields": False}}


def run(scene_dict: dict, comm=MPI.COMM_WORLD) -> dict[str, np.ndarray]:
    """Run the scene in-process; its time series as arrays."""
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import validate_scene
    from cosserat_fsi.observables import Observables
    from cosserat_fsi.simulation import Simulation

    sc = validate_scene(scene_dict)
    mesh, ct, ft, _ = load_mesh(sc, comm)
    sim = Simulation(sc, mesh, ct, ft, comm)
    obs = Observables(sim)
    rows = []
    sim.run(sim.steps_to(sc.time.t_end), observers=[lambda s: rows.append({"t": s.t, **obs.evaluate()})])
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}


def frequency(t: np.ndarray, y: np.ndarray) -> float:
    """The oscillation's frequency: the number of periods between its first and last upward crossings of
    the middle of its range (crossing times by linear interpolation) over the time between them."""
    z = y - 0.5 * (y.max() + y.min())
    up = np.nonzero((z[:-1] < 0) & (z[1:] >= 0))[0]
    times = t[up] - z[up] * (t[up + 1] - t[up]) / (z[up + 1] - z[up])
    if len(times) < 2:
        raise ValueError("fewer than two crossings")
    return (len(times) - 1) / (times[-1] - times[0])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[2, 4, 8])
    parser.add_argument("--law", default="saint_venant_kirchhoff")
    parser.add_argument("--t-end", type=float, default=3.0)
    parser.add_argument("--dt", type=float, default=0.01)
    parser.add_argument("--work", default=str(ROOT / "runs" / "thin_strip"))
    args = parser.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    reference = beam_frequency()
    print(f"Euler-Bernoulli: {reference:.4f} Hz (E' = {plane_strain_modulus():.4g} Pa)")
    for n in args.cells:
        series = run(scene(write_geo(work, n), args.law, args.dt, args.t_end))
        f = frequency(series["t"], series["uy_tip"])
        print(f"{args.law}, {n} cells across: f1 = {f:.4f} Hz ({100 * (f / reference - 1):+.2f} %), "
              f"tip deflection {series['uy_tip'].min():.4g} m", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
