"""Check runs of the sudden expansion against the exact developed flow, and show what the micropolar terms change.

    python examples/sudden_expansion/analyse.py runs/expansion [runs/expansion_newtonian ...] \
        [--plot docs/figures/sudden_expansion.png]

Far behind the step (x = 13, the channel 0 <= y <= 2, half-height h = 1) the flow is developed again: with
ω = 0 on both walls it is micropolar Poiseuille flow (shared/reference/micropolar_exact.md §1) with the
flow rate Q of the inlet; with ω = ½ curl u on both walls, or without micropolar terms, it is Newtonian
Poiseuille flow, u = G (h² − s²)/(2μ), ω = G s/(2μ) (s = y − 1). The probes ``centre`` (13, 1) and
``upper`` (13, 1.5) are compared with it. The reattachment length x_r (in step heights, 1) is where the
x-velocity sampled just above the floor (y = 0.01, from fields.xdmf) turns from negative to positive for
the last time; Δp is the pressure drop between the probes ``inlet_centre`` (1, 1.5) and ``centre``.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np
import yaml

STEP_X, HALF_HEIGHT, CENTRE_Y = 2.0, 1.0, 1.0
TOLERANCE = 1e-3
"""Relative tolerance of the developed u(13, 1) and ω(13, 1.5) against the exact flow (measured: about
2e-5 and 1e-5 on level 0; a 1 % change of μ_r moves u(13, 1) by 5e-4 of itself, ω by 2e-3)."""


def _final(run: Path) -> dict[str, float]:
    with open(run / "timeseries.csv") as f:
        rows = list(csv.DictReader(f))
    return {k: float(v) for k, v in rows[-1].items()}


def developed(config: dict, flow_rate: float, s: float) -> tuple[float, float | None]:
    """Exact (u, ω) of the developed flow at s = y − 1 behind the step, for the scene ``config`` (its
    config.yaml) and flow rate ``flow_rate``; ω None without micropolar terms."""
    from cosserat_fsi.exact import MicropolarPoiseuille

    mu, m = config["fluid"]["mu"], config["micropolar"]
    micro = m["mu_r"] > 0 or m["lambda1"] > 0
    h = HALF_HEIGHT
    if micro:
        default = m["wall_condition"]
        walls = {(config["boundaries"][name].get("micro_rotation") or default) for name in ("walls", "step")}
        if walls == {"zero"}:
            unit = MicropolarPoiseuille(1.0, h, mu, m["mu_r"], m["lambda1"], 0.0)
            exact = MicropolarPoiseuille(flow_rate / unit.flow_rate(), h, mu, m["mu_r"], m["lambda1"], 0.0)
            u, w = exact.profiles(np.array([[0.0], [h + s]]))
            return float(u[0]), float(w[0])
        if walls != {"half_curl"}:
            raise ValueError(f"no exact developed flow for wall conditions {sorted(walls)}")
    G = 3 * mu * flow_rate / (2 * h**3)  # Newtonian Poiseuille: Q = 2 G h³ / (3 μ)
    return G * (h * h - s * s) / (2 * mu), (G * s / (2 * mu) if micro else None)


def reattachment(run: Path, y: float = 0.01) -> float:
    """x_r − 2: where u_x(x, y) along the floor behind the step last turns from negative to positive."""
    import pyvista as pv

    reader = pv.get_reader(str(run / "fields.xdmf"))
    reader.set_active_time_value(reader.time_values[-1])
    mesh = reader.read()
    mesh = mesh[0] if isinstance(mesh, pv.MultiBlock) else mesh
    line = mesh.sample_over_line((STEP_X, y, 0.0), (13.9, y, 0.0), resolution=11900)
    x, ux = np.asarray(line.points)[:, 0], np.asarray(line["velocity"])[:, 0]
    up = np.nonzero((ux[:-1] < 0) & (ux[1:] >= 0))[0]
    if not len(up):
        return float("nan")
    k = up[-1]
    return float(x[k] - ux[k] * (x[k + 1] - x[k]) / (ux[k + 1] - ux[k]) - STEP_X)


def measure(run: Path) -> dict[str, dict[str, float | None]]:
    """Observables of one run: {name: {value, reference}} (reference None where there is none)."""
    config = yaml.safe_load((run / "config.yaml").read_text())
    final = _final(run)
    q = final["flow_rate"]
    u_ref, _ = developed(config, q, 0.0)
    _, w_ref = developed(config, q, 0.5)
    out = {"u_centre": {"value": final["u_centre"], "reference": u_ref},
           "flow_rate": {"value": q, "reference": 1.0}}
    if w_ref is not None:
        out["omega_upper"] = {"value": final["omega_upper"], "reference": w_ref}
    out["x_r"] = {"value": reattachment(run), "reference": None}
    out["dp"] = {"value": final["p_inlet_centre"] - final["p_centre"], "reference": None}
    return out


def plot(runs: list[Path], path: Path) -> None:
    """ω of the first run (as ParaView shows fields.xdmf: the P1 point data) and u_x along the floor of all."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.tri as mtri
    import pyvista as pv

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(11, 6.5), gridspec_kw={"height_ratios": [1.1, 1]})
    reader = pv.get_reader(str(runs[0] / "fields.xdmf"))
    reader.set_active_time_value(reader.time_values[-1])
    mesh = reader.read()
    mesh = mesh[0] if isinstance(mesh, pv.MultiBlock) else mesh
    cells = np.asarray(mesh.cells).reshape(-1, 4)[:, 1:]
    xy = np.asarray(mesh.points)[:, :2]
    w = np.asarray(mesh["micro_rotation"])
    lim = np.abs(w).max()
    art = top.tripcolor(mtri.Triangulation(xy[:, 0], xy[:, 1], cells), w, shading="gouraud", cmap="RdBu_r",
                        vmin=-lim, vmax=lim)
    fig.colorbar(art, ax=top, label="ω (1/s)", fraction=0.025)
    top.set_aspect("equal")
    top.set_title(f"micro-rotation ω, {runs[0].name}")
    for run in runs:
        r = pv.get_reader(str(run / "fields.xdmf"))
        r.set_active_time_value(r.time_values[-1])
        m = r.read()
        m = m[0] if isinstance(m, pv.MultiBlock) else m
        line = m.sample_over_line((STEP_X, 0.01, 0.0), (13.9, 0.01, 0.0), resolution=2000)
        bottom.plot(np.asarray(line.points)[:, 0], np.asarray(line["velocity"])[:, 0], label=run.name)
    bottom.axhline(0.0, color="0.5", lw=0.8)
    bottom.set_xlabel("x")
    bottom.set_ylabel("u_x(x, 0.01)")
    bottom.set_title("x-velocity just above the floor behind the step (negative: recirculation)")
    bottom.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run folders of examples/sudden_expansion/expansion.yaml")
    parser.add_argument("--plot", type=Path, help="PNG: ω of the first run, u_x along the floor of all")
    args = parser.parse_args(argv)
    ok = True
    for run in args.runs:
        print(run.name)
        for name, m in measure(run).items():
            if m["reference"] is None:
                print(f"  {name:12s} {m['value']:.6g}")
                continue
            err = m["value"] / m["reference"] - 1
            ok &= abs(err) <= TOLERANCE
            print(f"  {name:12s} {m['value']:.6g}  exact {m['reference']:.6g}  {err:+.2e} "
                  f"({'within' if abs(err) <= TOLERANCE else 'OUTSIDE'} {TOLERANCE:g})")
    if args.plot:
        plot(args.runs, args.plot)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
