"""The progress bar of `cosserat-fsi run` (tqdm, rank 0): steps to the last one, or with ``time.tolerance``
(the number of steps is not known in advance) simulated time to ``time.t_end``."""

from __future__ import annotations


def progress_bar(total: int, enabled: bool, t_end: float | None = None):
    """A bar counting steps to ``total``, or with ``t_end`` (time.tolerance: the number of steps is not
    known) counting simulated time to ``t_end``."""
    if not enabled:
        return None
    from tqdm import tqdm

    if t_end is not None:
        return tqdm(total=float(t_end), unit="s simulated", dynamic_ncols=True, mininterval=0.5,
                    bar_format="{l_bar}{bar}| t = {n:.4g}/{total:.4g} [{elapsed}<{remaining}{postfix}]")
    return tqdm(total=total, unit="step", dynamic_ncols=True, mininterval=0.5)


def advance(bar, sim) -> None:
    """Move the bar to the run's step (or, counting simulated time, to its t)."""
    if isinstance(bar.total, float):
        bar.update(min(sim.t, bar.total) - bar.n)
        bar.set_postfix_str(f"step {sim.step_count}, dt={sim.state.steps.last:.3g}", refresh=False)
    else:
        bar.update(sim.step_count - bar.n)
        bar.set_postfix_str(f"t={sim.t:.4g}", refresh=False)
