"""`make extremes`: numerical stability at the edges of parameter space.

Each case is the Turek–Hron FSI3 scene on the coarsest mesh (level 0, 2 s of flow with a 0.5 s ramp)
with one parameter pushed to an extreme. A case passes when it either completes with finite, bounded
energy (the total energy never exceeds 100 × the kinetic energy of the mean inflow over the whole
channel) or stops with exit code 3 and a `diverged:` message — never a silent NaN. The table goes into
docs/extremes.md; finished cases are not run again.

    python campaigns/extremes.py [--jobs 2] [--only PATTERN] [--out docs]
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import os
import sys
from pathlib import Path

import numpy as np

from cosserat_fsi.app import cases as app_cases
from pinned_law import FSI3_VOLUME_CORRECTION, INCOMPRESSIBLE

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))
CONFIG = "configs/turek_hron_fsi3.yaml"
BASE = {"geometry.level": 0, "time.dt": 0.005, "time.t_end": 2.0, "inflow.ramp_time": 0.5,
        "output.fields": False, "output.checkpoint_every": 0, "time.tolerance": None,  # fixed steps
        # the seed's scheme, as when docs/extremes.md was written (FSI3 ships ale_bdf2)
        "time.scheme": "characteristics1",
        # and its law (the shipped scene carries the benchmark's St Venant–Kirchhoff solid)
        **INCOMPRESSIBLE, **FSI3_VOLUME_CORRECTION}
MICRO = {"micropolar.lambda1": 1.0e-4, "micropolar.inertia": 1.0e-4}
# large deformations: the shipped scene files themselves (L1, BDF2, δt 0.002 or capped there, remeshing at
# q < 0.35), run to their end on 2 MPI ranks (their serial runs are in docs/perf_mesh_motion.md, "Remeshing")
LARGE = {"large-heavy-soft": ("configs/turek_hron_fsi3_heavy_soft.yaml: ρ_s = 10⁴, μ_s = 5·10⁵, ν = 0.4 (St Venant–"
                              "Kirchhoff, linear displacement), Ū = 1, adaptive step, t = 15",
                              "configs/turek_hron_fsi3_heavy_soft.yaml"),
         "large-heavy-soft-incompressible": ("configs/turek_hron_fsi3_heavy_soft_incompressible.yaml: the same flag "
                                             "incompressible, δt = 0.002",
                                             "configs/turek_hron_fsi3_heavy_soft_incompressible.yaml"),
         "large-soft-fast": ("configs/turek_hron_fsi3_soft_fast.yaml: μ_s ÷ 10 (2·10⁵), Ū = 2, t = 10",
                             "configs/turek_hron_fsi3_soft_fast.yaml")}
LARGE_RANKS = 2

# id -> (what, overrides)
CASES = {
    "baseline": ("FSI3 on the coarsest mesh (level 0), δt = 0.005", {}),
    "stiff-solid": ("μ_s × 1000 (2e9 Pa)", {"solid.mu_s": 2.0e9}),
    "soft-solid": ("μ_s ÷ 100 (2e4 Pa)", {"solid.mu_s": 2.0e4}),
    "light-solid": ("ρ_s/ρ_f = 0.01", {"solid.rho": 10.0}),
    "heavy-solid": ("ρ_s/ρ_f = 100", {"solid.rho": 1.0e5}),
    "dt-x10": ("δt × 10 (0.05: CFL ≈ 15 at the cylinder)", {"time.dt": 0.05}),
    "high-re": ("Re = 20,000 (μ = 0.01)", {"fluid.mu": 0.01}),
    "mu_r-1000": ("μ_r/μ = 1000", {**MICRO, "micropolar.mu_r": 1000.0}),
    "inertia-1e-6": ("micro-inertia I = 1e-6 m² (μ_r = 0.5)", {**MICRO, "micropolar.mu_r": 0.5,
                                                               "micropolar.inertia": 1.0e-6}),
}
# why each case behaves as it does (the table's last column)
WHY = {
    "baseline": "reference for the others; level 0 is too coarse to shed vortices by t = 2",
    "stiff-solid": "the solid terms are implicit (linearised around d^n): a stiff flag only makes the matrix "
                   "stiffer, the direct solve does not care",
    "soft-solid": "large, slow deformation (8 cm of tip motion on the coarsest mesh); the biharmonic mesh "
                  "motion (the default) keeps the cells valid without a remesh",
    "light-solid": "monolithic: fluid and solid are solved together, so there is no added-mass instability "
                   "(a partitioned scheme diverges at this density ratio)",
    "heavy-solid": "inertia dominates: a slow swing at a 10× lower natural frequency; nothing stiff for the implicit "
                   "solver",
    "dt-x10": "characteristics have no CFL limit; the first-order scheme only adds numerical viscosity "
              "≈ U²δt/2",
    "high-re": "characteristics + implicit viscosity stay stable at any Re; under-resolved (no accuracy claim)",
    "mu_r-1000": "the ω equation and its coupling are implicit, so a large μ_r only stiffens the system",
    "inertia-1e-6": "ρI/δt becomes negligible: ω is quasi-static, an algebraic constraint the monolithic "
                    "solve handles",
    "large-heavy-soft": "the compressible law at large deformation: the displacement linear on each cell, like the "
                        "mesh, keeps its mid-edge nodes on the mesh (with the quadratic one the run stops at t = "
                        "10.56); the step capped at 0.002 (uncapped: exit 3 at t = 7.79); no remesh needed (lowest "
                        "q 0.395)",
    "large-heavy-soft-incompressible": "the run that once stopped (harmonic mesh motion: exit 3 at t = 7.966); the "
                                       "biharmonic extension and remeshing keep the cells valid through the saturated "
                                       "swing (lowest q 0.340; 5,445 cells, 5,523–5,617 after the remeshes)",
    "large-soft-fast": "many centimetres of tip motion at the benchmark inflow, a 6.7 Hz swing; the biharmonic "
                       "extension keeps every fluid cell above q = 0.45, so no remesh is triggered (at q < 0.35); "
                       "2 ranks = 1 rank to 3e-12 m over the whole run",
}
ENERGY_BOUND = 100.0  # × ½ ρ_f Ū² |channel|


def run_case(case_id: str, runs: Path, python: str | None = None, extra: dict | None = None) -> Path:
    """Run one case (``extra``: further overrides, e.g. a shorter t_end in the tests)."""
    return app_cases.run_case(_case(case_id, runs, extra), python)


# what the adaptive runs at the extremes show (adaptive_section)
ADAPTIVE_WHY = {
    "fsi3-sudden": (
        "The sudden load does not break the fixed step: at δt = 0.005 the run completes inside FSI3's band "
        "(3 % / 1 %) with the numbers of the ramped run (the periodic state forgets the start; on level 0 it also "
        "completes at 0.01, 0.02 and 0.04). The adaptive run completes inside the band too, at 1.9 × the steps: "
        "between t = 0.01 and 0.9 it takes δt = 0.0003–0.0005 (1,700 steps) because it resolves what the start "
        "excites, the flag ringing in its higher modes (drag between −750 and +1,545 N for 0.1 < t < 0.5, "
        "against 434–558 N at δt = 0.005, where BDF2 damps the ringing out). From t ≈ 1 on its steps are "
        "those of the ramped run (0.0046–0.0061). No fixed δt that is fine on average fails here for the "
        "adaptive step to rescue; what it buys is a resolved transient."),
    "soft-fast": (
        "No reference: the scene as shipped (characteristics2, fixed δt = 0.002, 5,000 steps) completes with "
        "uy(A) 67.0 mm at 6.53 Hz (2 ranks; docs/runs/extreme-large-soft-fast); the adaptive run (3e-2) "
        "completes with 62.5 mm at 6.61 Hz in 6,457 steps + 65 rejected (1.3 × the solves), its steps "
        "0.0008–0.005 (median 0.0013, below the shipped 0.002) through the swing, no remesh (lowest q 0.42). The "
        "two differ by 6.7 % in amplitude and 1.3 % in frequency, over two periods each: the shipped δt is not "
        "converged in time here, and which of the two is nearer the converged swing is not measured. "
        "The extremes' case where a fixed step does fail (the coarsest mesh, μ_s ÷ 100 with the incompressible "
        "law and ale_bdf2: cells invert at t = 1.38 at δt = 0.005) fails with the adaptive step too (a "
        "non-finite solution at t = 1.28 even at dt_min): the flag's tip folds within a step of any size."),
}


def _case(case_id: str, runs: Path, extra: dict | None = None) -> app_cases.Case:
    if case_id in LARGE:
        return app_cases.Case(ROOT / LARGE[case_id][1], runs / f"extreme-{case_id}", dict(extra or {}), LARGE_RANKS)
    return app_cases.Case(ROOT / CONFIG, runs / f"extreme-{case_id}", {**BASE, **CASES[case_id][1], **(extra or {})})


def verdict(out: Path) -> dict:
    """What happened in a finished case folder: status, exit code, energy, message, pass/fail."""
    from cosserat_fsi.io import read_timeseries

    code = int((out / "exit_code").read_text()) if (out / "exit_code").exists() else None
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
    series = read_timeseries(out / "timeseries.csv") if (out / "timeseries.csv").exists() else {}
    energy = series.get("energy_total", np.zeros(0))
    values = np.concatenate([v for k, v in series.items() if k != "t"]) if series else np.zeros(0)
    finite = bool(np.isfinite(values).all())
    scale = 0.5 * 1000.0 * 2.0**2 * 2.5 * 0.41  # ½ ρ_f Ū² |channel| (J per m)
    bounded = finite and (energy.max(initial=0.0) <= ENERGY_BOUND * scale)
    status = summary.get("status", "?")
    message = summary.get("message", "")
    ok = (code == 0 and status == "completed" and bounded) or (code == 3 and status == "diverged" and message)
    return {"status": status, "exit": code, "finite": finite, "energy_max": float(energy.max(initial=0.0)),
            "energy_scale": scale, "uy_max": float(np.abs(series.get("uy_A", np.zeros(1))).max(initial=0.0)),
            "steps": len(series.get("t", [])), "message": message, "ok": bool(ok),
            "per_step": summary.get("wall_time", {}).get("per_step"),
            "remeshes": summary.get("remeshes", {}).get("count"),
            "lowest_quality": summary.get("mesh_quality", {}).get("lowest")}


def write_report(runs: Path, out: Path) -> Path:
    rows = ["| case | what | outcome | steps | max energy / scale | max \\|uy(A)\\| (mm) | remeshes | s/step | ok "
            "| why |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for case_id, (what, _) in {**CASES, **LARGE}.items():
        folder = runs / f"extreme-{case_id}"
        if not (folder / "exit_code").exists():
            rows.append(f"| {case_id} | {what} | not run | | | | | | | |")
            continue
        v = verdict(folder)
        outcome = ("completed, bounded energy" if v["status"] == "completed" and v["ok"] else
                   f"exit {v['exit']}: {v['message'] or v['status']}")
        rows.append(f"| {case_id} | {what} | {outcome} | {v['steps']} | {v['energy_max'] / v['energy_scale']:.3g} | "
                    f"{1e3 * v['uy_max']:.3g} | {'' if v['remeshes'] is None else v['remeshes']} | "
                    f"{v['per_step'] or 0:.3f} | {'yes' if v['ok'] else '**no**'} | "
                    f"{WHY.get(case_id, '')} |")
    lines = ["# Extremes", "",
             "Written by `make extremes` (`python campaigns/extremes.py`). Each case is "
             f"`{CONFIG}` on the coarsest mesh with "
             f"`{' '.join(app_cases.override(k, v) for k, v in BASE.items())}` and one "
             "parameter pushed to an extreme; the `large-*` cases are their scene files as shipped, "
             f"run to their end on {LARGE_RANKS} MPI ranks. *ok* means: completed with "
             "finite energy below "
             f"{ENERGY_BOUND:g} × ½ ρ_f Ū² |channel| (the scale column divides by that), or stopped with exit "
             "code 3 and a `diverged:` message naming when and where — never a silent NaN.", "", *rows, ""]
    lines += adaptive_section(out / "perf" / "adaptive" / "extremes.json")
    path = out / "extremes.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def adaptive_section(rows_file: Path) -> list[str]:
    """The adaptive step (``time.tolerance``) against the fixed δt on the extreme scenes: the rows that
    campaigns/adaptive_ladder.py wrote to ``rows_file`` (its table per scene), and what they show."""
    if not rows_file.exists():
        return []
    sys.path.insert(0, str(ROOT / "campaigns"))
    from adaptive_ladder import SCENES, table

    rows = json.loads(rows_file.read_text())
    lines = ["## The adaptive step at the extremes", "",
             "`python campaigns/adaptive_ladder.py --scene SCENE --fixed --tolerances … --json "
             f"{rows_file.resolve().relative_to(ROOT)}` (L1, from rest, serial; the errors are the periodic "
             "analysis of the scene's observable over the second half in time against the benchmark's reference):",
             ""]
    for scene in dict.fromkeys(r["scene"] for r in rows):
        config, overrides, name, _ = SCENES[scene]
        lines += [f"### {scene}: `{config}`" + (f" with `{' '.join(f'{k}={v}' for k, v in overrides.items())}`"
                                                if overrides else "") + f" ({name})", "",
                  table([r for r in rows if r["scene"] == scene]).split("\n\nlog–log")[0], "",
                  ADAPTIVE_WHY.get(scene, ""), ""]
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python campaigns/extremes.py", description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--only", default="*")
    parser.add_argument("--out", default=str(ROOT / "docs"))
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args(argv)
    out = Path(args.out)
    runs = out / "runs"
    chosen = [c for c in (*CASES, *LARGE) if fnmatch.fnmatch(c, args.only)]
    if not args.report_only:
        app_cases.run_cases([_case(c, runs) for c in chosen], args.jobs,
                            report=lambda done: print(f"finished {done.name}", flush=True))
    print(write_report(runs, out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
