"""The Pareto fronts of a study (cost against error, per series) and their figure."""

from __future__ import annotations

from pathlib import Path


def pareto(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points (cost, error) that no other point beats in both (lower is better)."""
    front = []
    for i, (c, e) in enumerate(points):
        if not any((c2 <= c and e2 <= e) and (c2 < c or e2 < e) for j, (c2, e2) in enumerate(points) if j != i):
            front.append(i)
    return front


GROUPS = ("fixed δt", "time.tolerance")  # the two series of the Pareto plot


def fronts(points: list[tuple[float, float]], groups: list[str]) -> dict[str, list[int]]:
    """{group: indices of its Pareto front}: the fixed-step runs and the runs with a time.tolerance each
    have their own front (a group without runs is left out)."""
    out = {}
    for group in GROUPS:
        members = [i for i, g in enumerate(groups) if g == group]
        if members:
            out[group] = [members[j] for j in pareto([points[i] for i in members])]
    return out


def quantity_fronts(observables: list[str], walls: list[float], errors: list[list[float]],
                    labels: list[str]) -> list[str]:
    """Markdown rows ``| quantity | front |``: for each observable, the runs no other run beats in both wall
    time and that quantity's |error| (fastest first), each with its error and wall time."""
    rows = ["| quantity | Pareto front: run (error, wall time), fastest first |", "|---|---|"]
    for k, name in enumerate(observables):
        points = [(w, abs(e[k])) for w, e in zip(walls, errors)]
        members = sorted(pareto(points), key=lambda i: walls[i])
        rows.append(f"| {name} | " + ", ".join(f"`{labels[i]}` ({100 * errors[i][k]:+.3g} %, {walls[i]:.3g} s)"
                                                for i in members) + " |")
    return rows


def pareto_figure(study, points, labels, groups, front):
    """The Pareto plot: worst error against wall time, one labelled series (runs and front) per group. A
    figure outside pyplot: the caller's matplotlib backend (a notebook's inline one) is left as it is."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 4.5))
    ax = fig.subplots()
    xs, ys = [p[0] for p in points], [max(p[1], 1e-6) for p in points]
    for group, members in front.items():
        mine = [i for i, g in enumerate(groups) if g == group]
        colour, marker = ("C0", "o") if group == GROUPS[0] else ("C3", "s")
        ax.loglog([xs[i] for i in mine], [ys[i] for i in mine], marker, color=colour, alpha=0.5, ls="none",
                  label=f"{group} runs")
        f = sorted(members, key=lambda i: xs[i])
        ax.loglog([xs[i] for i in f], [ys[i] for i in f], "-" + marker, color=colour,
                  label=f"{group}: Pareto front")
    for x, y, label in zip(xs, ys, labels):
        ax.annotate(label, (x, y), fontsize=6, xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("worst relative error of " + ", ".join(study.observables))
    ax.set_title(f"study {study.name}: accuracy against cost")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def save_pareto_figure(study, points, labels, groups, front, out: Path) -> str:
    """The Pareto plot as OUT/figures/study_NAME_pareto.png; its path relative to OUT."""
    fig = pareto_figure(study, points, labels, groups, front)
    path = out / "figures" / f"study_{study.name}_pareto.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    return str(path.relative_to(out))
