"""Variable-step BDF: the weights of a step whose size differs from the last one's, the extrapolation to
t^{n+1}, and the embedded error estimate of the step (time_control.py chooses the step from it).

With ω = δt_n/δt_{n−1} (δt_n = t^{n+1} − t^n), BDF2 is

    α u^{n+1} − (a₁ u^n − a₂ u^{n−1}) = δt_n u̇^{n+1},   α = (1 + 2ω)/(1 + ω), a₁ = 1 + ω, a₂ = ω²/(1 + ω),

the constant-step weights 3/2, 2, ½ at ω = 1 (bit for bit: the operations are those of the constant-step
formulas). The extrapolation u* = (1 + ω)u^n − ωu^{n−1} is linear through t^{n−1}, t^n; the characteristics'
second foot is at x − (δt_n + δt_{n−1}) u*. The first order scheme (and BDF2's first step) is backward
Euler: α = a₁ = 1, a₂ = 0.

Error estimate (Milne's device): the step's solution minus the explicit predictor (BDF2: the quadratic
through u^{n−2}, u^{n−1}, u^n; backward Euler: the line through u^{n−1}, u^n), times C/(C + C_P) with C the
local error constant of the corrector and C_P the predictor's interpolation error: BDF2's local error is
δt³u‴(1 + ω)²/(6ω(1 + 2ω)) (2/9 δt³u‴ at ω = 1), the quadratic predictor's δt(δt + k₁)(δt + k₁ + k₂)u‴/6 with
k₁, k₂ the two steps before (δt³u‴ at constant steps): the classical factor 2/11 at constant steps.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BdfWeights:
    """The weights of one BDF step of size ``dt`` (``order`` 1: backward Euler; 2: BDF2 with the step ratio
    ``ratio`` ω = δt_n/δt_{n−1})."""

    order: int
    dt: float
    ratio: float = 1.0

    @property
    def alpha(self) -> float:
        return 1.0 if self.order == 1 else (1.0 + 2.0 * self.ratio) / (1.0 + self.ratio)

    @property
    def a1(self) -> float:
        return 1.0 if self.order == 1 else 1.0 + self.ratio

    @property
    def a2(self) -> float:
        return 0.0 if self.order == 1 else self.ratio * self.ratio / (1.0 + self.ratio)

    def history(self, f_n, f_nm1):
        """α h = a₁ f^n − a₂ f^{n−1} (first order: f^n)."""
        return f_n if self.order == 1 else self.a1 * f_n - self.a2 * f_nm1

    def base(self, f_n, f_nm1):
        """f* = α h/α, with f^{n+1} = f* + (δt/α) ḟ^{n+1} (eq. 28's d*; BDF2 at ω = 1: (4f^n − f^{n−1})/3)."""
        if self.order == 1:
            return f_n
        if self.ratio == 1.0:
            return (4.0 * f_n - f_nm1) / 3.0
        return self.history(f_n, f_nm1) / self.alpha

    def extrapolated(self, f_n, f_nm1):
        """f* = (1 + ω) f^n − ω f^{n−1}: f at t^{n+1} to O(δt²) (first order: f^n)."""
        return f_n if self.order == 1 else self.a1 * f_n - self.ratio * f_nm1

    @property
    def second_foot(self) -> float:
        """t^{n+1} − t^{n−1} = δt_n (1 + 1/ω): how far back u* is followed to u^{n−1}."""
        return 2.0 * self.dt if self.ratio == 1.0 else self.dt * (1.0 + 1.0 / self.ratio)


def estimate_factor(order: int, dt: float, k1: float, k2: float) -> float:
    """C/(C + C_P) of the error estimate (module docstring): the step ``dt`` after steps ``k1`` = t^n − t^{n−1}
    and ``k2`` = t^{n−1} − t^{n−2}. First order: δt/(2δt + k₁) (backward Euler against the line)."""
    if order == 1:
        return dt / (2.0 * dt + k1)
    w = dt / k1
    corrector = dt ** 3 * (1.0 + w) ** 2 / (6.0 * w * (1.0 + 2.0 * w))
    predictor = dt * (dt + k1) * (dt + k1 + k2) / 6.0
    return corrector / (corrector + predictor)


def predicted(order: int, dt: float, k1: float, k2: float, f_n, f_nm1, f_nm2=None):
    """The explicit predictor of f^{n+1}: the quadratic through f^{n−2}, f^{n−1}, f^n (order 2) or the line
    through f^{n−1}, f^n (order 1), at t^{n+1} = t^n + ``dt``."""
    if order == 1:
        return f_n + (dt / k1) * (f_n - f_nm1)
    l0 = (dt + k1) * (dt + k1 + k2) / (k1 * (k1 + k2))
    l1 = -dt * (dt + k1 + k2) / (k1 * k2)
    l2 = dt * (dt + k1) / ((k1 + k2) * k2)
    return l0 * f_n + l1 * f_nm1 + l2 * f_nm2
