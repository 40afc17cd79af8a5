"""Compare runs of the perpendicular flap with the preCICE reference logs: first peak, period, a plot.

    python examples/perpendicular_flap/compare.py --reference DIR --plot docs/figures/perpendicular_flap.png \
        "L0, dt 0.01=runs/flap/timeseries.csv" ...

DIR holds ``perpendicular_flap_openfoam-*.txt`` (the tip watchpoint logs of the OpenFOAM pairs, columns
Time ... Displacement0 ...; see shared/reference/perpendicular_flap.md). The first peak is the first local
maximum of the tip's x-displacement, refined by a parabola through it and its neighbours; the period is the
mean distance between successive maxima. Bands: first peak within 5 %, period within 3 % of the
OpenFOAM pairs' consensus.
"""

from __future__ import annotations

import argparse
import csv
import glob
import os

import numpy as np

CONSENSUS = ("openfoam-calculix", "openfoam-dealii", "openfoam-dune", "openfoam-fenics")
"""The OpenFOAM pairs that agree (first peak 0.198-0.199 m, period 1.60-1.63 s); openfoam-nutils (P1 solid,
2 x 20 elements, first order in time) and openfoam-solids4foam lie 12-15 % lower and are shown, not averaged."""


def peaks(t: np.ndarray, u: np.ndarray) -> list[tuple[float, float]]:
    """Local maxima (time, value), each refined by the parabola through three samples."""
    out = []
    for k in range(1, len(u) - 1):
        if u[k] > u[k - 1] and u[k] >= u[k + 1]:
            a, b, c = u[k - 1], u[k], u[k + 1]
            den = a - 2 * b + c
            s = 0.5 * (a - c) / den if den != 0 else 0.0
            dt = t[k + 1] - t[k]
            out.append((t[k] + s * dt, b - 0.25 * (a - c) * s))
    return out


def swings(t: np.ndarray, u: np.ndarray) -> list[tuple[float, float]]:
    """The largest local maximum of each swing: between two kept maxima the signal falls below the middle of
    its range (a wiggle near a crest, as at δt = 0.005 near t = 2.25, is not a period)."""
    middle = 0.5 * (np.nanmax(u) + np.nanmin(u))
    kept: list[tuple[float, float]] = []
    for tp, up in peaks(t, u):
        if kept and not np.any(u[(t > kept[-1][0]) & (t < tp)] < middle):
            if up > kept[-1][1]:
                kept[-1] = (tp, up)
            continue
        kept.append((tp, up))
    return kept


def summary(t: np.ndarray, u: np.ndarray) -> dict[str, float]:
    """First peak time and value, and the mean period between the swings' maxima."""
    p = swings(t, u) or [(np.nan, np.nan)]  # none yet (a short run): NaN
    times = [q[0] for q in p]
    return {"t_peak": p[0][0], "peak": p[0][1], "period": float(np.mean(np.diff(times))) if len(p) > 1 else np.nan,
            "n_peaks": len(p)}


def references(folder: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The OpenFOAM pairs' tip x-displacement logs in ``folder``: {pair: (t, ux)}."""
    refs = {}
    for path in sorted(glob.glob(os.path.join(folder, "perpendicular_flap_openfoam-*.txt"))):
        data = np.loadtxt(path, skiprows=2)
        refs[os.path.basename(path)[len("perpendicular_flap_"):-4]] = (data[:, 0], data[:, 3])
    return refs


def consensus(refs: dict) -> tuple[float, float]:
    """Mean first peak (m) and period (s) of the :data:`CONSENSUS` pairs."""
    return (float(np.mean([summary(*refs[k])["peak"] for k in CONSENSUS if k in refs])),
            float(np.mean([summary(*refs[k])["period"] for k in CONSENSUS if k in refs])))


def read_tip(path: str) -> tuple[np.ndarray, np.ndarray]:
    """(t, ux_tip) of a run's timeseries.csv."""
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return np.array([float(r["t"]) for r in rows]), np.array([float(r["ux_tip"]) for r in rows])


def plot(refs: dict, ours: dict, path: str) -> None:
    """Our tip x-displacement curves (``ours``: {label: (t, ux)}) over the OpenFOAM pairs' (grey)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    for i, (t, u) in enumerate(refs.values()):
        ax.plot(t, u, color="0.6", lw=1, label="OpenFOAM pairs (preCICE)" if i == 0 else None)
    for label, (t, u) in ours.items():
        ax.plot(t, u, lw=1.5, label=f"cosserat-fsi {label}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("tip x-displacement (m)")
    ax.set_title("preCICE perpendicular flap: tip x-displacement")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="LABEL=path/to/timeseries.csv")
    parser.add_argument("--reference", required=True, help="folder with perpendicular_flap_openfoam-*.txt")
    parser.add_argument("--plot", help="PNG to write")
    args = parser.parse_args()
    refs = references(args.reference)
    ref_peak, ref_period = consensus(refs)
    print(f"{'run':34s} {'t_peak':>7s} {'peak':>8s} {'dev':>7s} {'period':>7s} {'dev':>7s}")
    for name, (t, u) in refs.items():
        s = summary(t, u)
        print(f"{name:34s} {s['t_peak']:7.3f} {s['peak']:8.4f} {'':7s} {s['period']:7.3f}")
    ours = {}
    for spec in args.runs:
        label, path = spec.split("=", 1) if "=" in spec else (spec, spec)
        load = float(label.split("load x", 1)[1].split()[0]) if "load x" in label else 1.0  # "... load x0.5"
        t, u = ours[label] = read_tip(path)
        s = summary(t, u)
        print(f"{label:34s} {s['t_peak']:7.3f} {s['peak']:8.4f} {100 * (s['peak'] / (load * ref_peak) - 1):+6.1f}% "
              f"{s['period']:7.3f} {100 * (s['period'] / ref_period - 1):+6.1f}%")
    print(f"OpenFOAM consensus: first peak {ref_peak:.4f} m, period {ref_period:.4f} s")
    if args.plot:
        plot(refs, ours, args.plot)


if __name__ == "__main__":
    main()
