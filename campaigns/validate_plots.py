"""The figures of docs/validation.md (campaigns/validate.py): written from the runs' time series, or the
earlier figure when a checkout keeps only the runs' summary.json."""

from __future__ import annotations

from pathlib import Path

from validate_cases import C1_VALUES, REFERENCE, _example

def save_figure(fig, out: Path, name: str) -> str:
    """Save a figure as docs/figures/<name> and return its path relative to ``out``."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path = out / "figures" / name
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return str(path.relative_to(out))


def _existing(out: Path, name: str) -> str | None:
    """An earlier figure (its runs' time series are not kept in a checkout: only their summary.json)."""
    path = out / "figures" / name
    return str(path.relative_to(out)) if path.exists() else None


def plot_cfd3(cases, runs: Path, out: Path) -> str | None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cosserat_fsi.io import read_timeseries
    from cosserat_fsi.references import reference_for

    ref = reference_for("turek_hron_cfd3")["lift"]
    fig, ax = plt.subplots(figsize=(9, 4))
    drawn = False
    for case in cases:
        csv = runs / case.id / "timeseries.csv"
        if case.id.startswith("cfd3") and csv.exists():
            ts = read_timeseries(csv)
            keep = ts["t"] >= ts["t"][-1] - 1.0
            ax.plot(ts["t"][keep], ts["lift"][keep], label=case.id, lw=1)
            drawn = True
    if not drawn:
        plt.close(fig)
        return _existing(out, "cfd3_lift.png")
    lo, hi = ref["mean"] - ref["amplitude"], ref["mean"] + ref["amplitude"]
    ax.axhspan(lo, hi, color="0.85", zorder=0, label="Turek–Hron CFD3 lift range")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("lift (N)")
    ax.legend(fontsize=7, loc="upper right")
    ax.set_title("CFD3: lift over the last simulated second")
    return save_figure(fig, out, "cfd3_lift.png")


def plot_tip(cases, runs: Path, out: Path, prefix: str, name: str, title: str) -> str | None:
    """uy(A)(t) of the cases whose id starts with ``prefix``, with the FSI3 reference band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cosserat_fsi.io import read_timeseries
    from cosserat_fsi.references import reference_for

    series = [(c.id, runs / c.id / "timeseries.csv") for c in cases if c.id.startswith(prefix)]
    series = [(i, p) for i, p in series if p.exists()]
    if not series:
        return _existing(out, name)
    ref = reference_for("turek_hron_fsi3")["uy_A"]
    fig, (ax, zoom) = plt.subplots(1, 2, figsize=(13, 4), gridspec_kw={"width_ratios": [2, 1]})
    for label, csv in series:
        ts = read_timeseries(csv)
        ax.plot(ts["t"], ts["uy_A"], lw=0.8, label=label)
        last = ts["t"] >= ts["t"][-1] - 0.5
        zoom.plot(ts["t"][last], ts["uy_A"][last], lw=1.0, label=label)
    for a in (ax, zoom):
        a.axhspan(ref["mean"] - ref["amplitude"], ref["mean"] + ref["amplitude"], color="0.85", zorder=0,
                  label="Turek–Hron FSI3 range of uy(A)")
        a.set_xlabel("t (s)")
    ax.set_ylabel("uy(A) (m)")
    ax.set_title(title)
    zoom.set_title("last 0.5 s")
    ax.legend(fontsize=7, loc="lower left")
    return save_figure(fig, out, name)


def plot_c1_sweep(runs: Path, out: Path) -> str | None:
    """Seed figures 5–6: uy(A)(t) for each c₁ and the oscillation amplitude against c₁."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cosserat_fsi.analysis import periodic_analysis
    from cosserat_fsi.io import read_timeseries

    done = [(c1, runs / f"c1sweep-{c1:.3g}" / "timeseries.csv") for c1 in C1_VALUES]
    done = [(c1, p) for c1, p in done if p.exists()]
    if not done:
        return _existing(out, "seed_fig5_6_c1_sweep.png")
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    amps = []
    for c1, csv in done:
        ts = read_timeseries(csv)
        ax1.plot(ts["t"], ts["uy_A"], lw=0.7, label=f"c1 = {c1:.3g}")
        a = periodic_analysis(ts["t"], ts["uy_A"]).get("amplitude")
        amps.append((c1, a if a is not None else 0.0))
    ax1.set_xlabel("t (s)")
    ax1.set_ylabel("uy(A) (m)")
    ax1.set_title("seed fig. 5: tip displacement for several c1")
    ax1.legend(fontsize=7)
    ax2.plot([a[0] for a in amps], [a[1] for a in amps], "o-")
    ax2.set_xlabel("c1 (μ_s = 2 c1)")
    ax2.set_ylabel("amplitude of uy(A) (m)")
    ax2.set_title("seed fig. 6: amplitude against c1")
    return save_figure(fig, out, "seed_fig5_6_c1_sweep.png")


def plot_flap(cases, runs: Path, out: Path) -> str | None:
    """The flap cases' tip x-displacement over the OpenFOAM pairs' (examples/perpendicular_flap/compare.py)."""
    series = [(c.id, runs / c.id / "timeseries.csv") for c in cases if c.id.startswith("flap-")]
    series = [(i, p) for i, p in series if p.exists()]
    name = "perpendicular_flap_ux_tip.png"
    if not series or not REFERENCE.is_dir():
        return _existing(out, name)
    compare = _example("perpendicular_flap/compare.py")
    (out / "figures").mkdir(parents=True, exist_ok=True)
    compare.plot(compare.references(str(REFERENCE)), {i: compare.read_tip(str(p)) for i, p in series},
                 str(out / "figures" / name))
    return f"figures/{name}"


def plot_expansion(cases, runs: Path, out: Path) -> str | None:
    """ω of the shipped sudden expansion and u_x along the floor of its variants (examples/sudden_expansion)."""
    order = ["expansion-L1", "expansion-L1-half-curl", "expansion-L1-newtonian-mu", "expansion-L1-newtonian-mu+mu_r"]
    found = [runs / i for i in order if (runs / i / "fields.xdmf").exists()]
    name = "sudden_expansion.png"
    if not found:
        return _existing(out, name)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    _example("sudden_expansion/analyse.py").plot(found, out / "figures" / name)
    return f"figures/{name}"

