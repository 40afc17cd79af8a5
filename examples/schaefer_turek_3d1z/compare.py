"""c_D, c_L and Δp of runs of the Schäfer–Turek 3D-1Z user scene against the benchmark's reference.

    python examples/schaefer_turek_3d1z/compare.py runs/duct [LABEL=runs/duct-h4 ...] [--tolerance 0.5]

Each argument is a run folder (``cosserat-fsi run duct.yaml --out FOLDER``), optionally ``LABEL=FOLDER``.
From the folder's summary.json (its last row of observables): c = 2 F / (ρ Ū² D H) with Ū = 0.2 (the mean of
the inflow profile), D H = 0.1 × 0.41 = 0.041, F the force on ``obstacle`` in residual form (``drag``,
``lift`` = the y component; ``drag_surface`` and ``lift_surface`` are the surface integral of −Tn, less
accurate), Δp = p_front − p_back, the pressure at (0.45, 0.2, 0.205) and (0.55, 0.2, 0.205). Reference:
cosserat_fsi/data/three_d_references.yaml (c_D 6.18533, c_L 0.009401: Braack & Richter 2006; Δp 0.170827:
FEAT3). Exit status 1 when a value is off by more than the tolerance (percent, default 0.5).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

U_MEAN, D_H = 0.2, 0.1 * 0.41
QUANTITIES = ("c_D", "c_L", "dp")


def reference() -> dict[str, float]:
    """The 3D-1Z reference values {c_D, c_L, dp} (cosserat_fsi/data/three_d_references.yaml)."""
    from importlib import resources

    import yaml

    text = resources.files("cosserat_fsi.data").joinpath("three_d_references.yaml").read_text()
    case = yaml.safe_load(text)["schaefer_turek_3d"]["cases"]["3D-1Z"]
    return {key: float(case[key]) for key in QUANTITIES}


def coefficients(run: str | Path) -> dict[str, float]:
    """{c_D, c_L, dp, c_D_surface, c_L_surface} of a completed run folder."""
    summary = json.loads((Path(run) / "summary.json").read_text())
    if summary.get("status") != "completed":
        raise SystemExit(f"{run}: status {summary.get('status')!r}, not completed")
    final = summary["final"]
    rho = summary["resolved_scene"]["fluid"]["rho"]
    scale = 2.0 / (rho * U_MEAN**2 * D_H)
    return {"c_D": scale * final["drag"], "c_L": scale * final["lift"], "dp": final["p_front"] - final["p_back"],
            "c_D_surface": scale * final["drag_surface"], "c_L_surface": scale * final["lift_surface"]}


def errors(values: dict[str, float], ref: dict[str, float]) -> dict[str, float]:
    """Relative errors in percent of c_D, c_L and dp."""
    return {key: 100.0 * (values[key] / ref[key] - 1.0) for key in QUANTITIES}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="FOLDER or LABEL=FOLDER")
    parser.add_argument("--tolerance", type=float, default=0.5, help="percent (default 0.5)")
    args = parser.parse_args()
    ref = reference()
    print(f"{'run':28s} {'c_D':>9s} {'err':>8s} {'c_L':>9s} {'err':>8s} {'dp':>9s} {'err':>8s}  within")
    print(f"{'reference':28s} {ref['c_D']:9.5f} {'':8s} {ref['c_L']:9.6f} {'':8s} {ref['dp']:9.6f}")
    failed = False
    for spec in args.runs:
        label, folder = spec.split("=", 1) if "=" in spec else (spec, spec)
        values = coefficients(folder)
        err = errors(values, ref)
        ok = all(abs(e) <= args.tolerance for e in err.values())
        failed |= not ok
        print(f"{label:28s} {values['c_D']:9.5f} {err['c_D']:+7.3f}% {values['c_L']:9.6f} {err['c_L']:+7.2f}% "
              f"{values['dp']:9.6f} {err['dp']:+7.3f}%  {'yes' if ok else 'no'}")
    raise SystemExit(1 if failed else 0)


if __name__ == "__main__":
    main()
