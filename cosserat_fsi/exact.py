"""Exact micropolar solutions (shared/reference/micropolar_exact.md) as scenes: their initial and boundary
data, and the relative L² errors a run reports against them.

``benchmark: micropolar_poiseuille`` (geometry ``channel``): steady Poiseuille flow between walls y = 0 and
y = height with ω = 0 on the walls, pressure gradient G = 1, do-nothing outlet (reference §1).
``benchmark: micropolar_taylor_green`` (geometry ``square`` of side π): the decaying micropolar
Taylor–Green vortex, amplitudes (F, W) from a 2×2 linear ODE (reference §2, k = 1).
The parameters are the scene's ``fluid`` (ρ, μ) and ``micropolar`` (μ_r, λ₁, I) sections.
"""

from __future__ import annotations

import numpy as np
import ufl


class _Lib:
    """numpy or UFL namespace, so one formula gives interpolation data and the exact UFL expression."""

    def __init__(self, ufl_mode):
        self.ufl = ufl_mode
        mod = ufl if ufl_mode else np
        self.sin, self.cos, self.sinh, self.cosh = mod.sin, mod.cos, mod.sinh, mod.cosh

    def vec(self, a, b):
        return ufl.as_vector((a, b)) if self.ufl else np.vstack([a, b + 0.0 * a])


NP, UFL = _Lib(False), _Lib(True)


class MicropolarPoiseuille:
    """Steady Poiseuille flow between walls y = 0 and y = 2h, ω = 0 on the walls, p = G (L − x)
    (zero at the do-nothing outlet x = L). Reference §1 with y → y − h."""

    def __init__(self, G, h, mu, mu_r, lambda1, L):
        self.G, self.h, self.mu, self.mu_r, self.lambda1, self.L = G, h, mu, mu_r, lambda1, L
        self.k = np.sqrt(4 * mu * mu_r / (lambda1 * (mu + mu_r)))

    def profiles(self, x, lib=NP):
        G, h, mu, mu_r, k = self.G, self.h, self.mu, self.mu_r, self.k
        y = x[1] - h
        u = (G / (2 * mu) * (h * h - y * y)
             - mu_r * G * h / (mu * (mu + mu_r) * k) * (np.cosh(k * h) - lib.cosh(k * y)) / np.sinh(k * h))
        w = G / (2 * mu) * (y - h * lib.sinh(k * y) / np.sinh(k * h))
        return u, w

    def flow_rate(self):
        G, h, mu, mu_r, k = self.G, self.h, self.mu, self.mu_r, self.k
        return 2 * G * h**3 / (3 * mu) - 2 * mu_r * G * h**2 / (mu * (mu + mu_r) * k) * (
            1 / np.tanh(k * h) - 1 / (k * h))

    def velocity(self, x, t, lib=NP):
        return lib.vec(self.profiles(x, lib)[0], 0.0 * x[0])

    def micro_rotation(self, x, t, lib=NP):
        return self.profiles(x, lib)[1]

    def pressure(self, x, t):
        return self.G * (self.L - x[0])


class MicropolarCouette:
    """Steady micropolar Couette flow between y = 0 (at rest, ω = a) and y = H (velocity U, ω = b), no
    pressure gradient: (μ + μ_r) u'' + 2μ_r ω' = 0 and λ₁ ω'' − 4μ_r ω − 2μ_r u' = 0 (eqs. 31–32 in 1D; 2D
    curl u = −u'). The first integrates to (μ + μ_r) u' + 2μ_r ω = C; then ω'' − k² ω = 2μ_r C / (λ₁ (μ + μ_r))
    with k² = 4μμ_r / (λ₁ (μ + μ_r)), so ω = −C/(2μ) + A cosh(ks) + B sinh(ks), s = y − H/2; (C, A, B) from
    ω(0) = a, ω(H) = b, u(H) = U."""

    def __init__(self, U, a, b, mu, mu_r, lambda1, H=1.0):
        self.H, self.mu, self.mu_r = H, mu, mu_r
        self.k = k = np.sqrt(4 * mu * mu_r / (lambda1 * (mu + mu_r)))
        ch, sh = np.cosh(k * H / 2), np.sinh(k * H / 2)
        self.C, self.A, self.B = np.linalg.solve([[-1 / (2 * mu), ch, -sh], [-1 / (2 * mu), ch, sh],
                                                  [H / mu, -4 * mu_r * sh / (k * (mu + mu_r)), 0.0]], [a, b, U])

    def profiles(self, y):
        """u(y), ω(y)."""
        mu, mu_r, k, m = self.mu, self.mu_r, self.k, self.mu + self.mu_r
        C, A, B, eta = self.C, self.A, self.B, self.H / 2
        ch, sh, s = np.cosh(k * eta), np.sinh(k * eta), np.asarray(y) - eta
        omega = -C / (2 * mu) + A * np.cosh(k * s) + B * np.sinh(k * s)
        u = (C * np.asarray(y) * m / mu
             - 2 * mu_r * (A / k * (np.sinh(k * s) + sh) + B / k * (np.cosh(k * s) - ch))) / m
        return u, omega


class MicropolarTaylorGreen:
    """Reference §2 (k = 1) on [0, π]²: F, W from the 2×2 linear ODE, (F, W)(0) = (1, 0)."""

    def __init__(self, rho, inertia, mu, mu_r, lambda1):
        self.rho = rho
        self.matrix = np.array([[-2 * (mu + mu_r) / rho, 2 * mu_r / rho],
                                [4 * mu_r / (rho * inertia), -(2 * lambda1 + 4 * mu_r) / (rho * inertia)]])
        self.eigenvalues, self.vectors = np.linalg.eig(self.matrix)
        self.coefficients = np.linalg.solve(self.vectors, [1.0, 0.0])

    def amplitudes(self, t):
        """(F, W)(t) = V exp(Λ t) V⁻¹ (1, 0)."""
        return (self.vectors @ (np.exp(self.eigenvalues * t) * self.coefficients)).real

    def velocity(self, x, t, lib=NP):
        F = self.amplitudes(t)[0]
        return lib.vec(F * lib.sin(x[0]) * lib.cos(x[1]), -F * lib.cos(x[0]) * lib.sin(x[1]))

    def micro_rotation(self, x, t, lib=NP):
        return self.amplitudes(t)[1] * lib.sin(x[0]) * lib.sin(x[1])

    def pressure(self, x, t):
        F = self.amplitudes(t)[0]
        return self.rho / 4 * F**2 * (np.cos(2 * x[0]) + np.cos(2 * x[1]))


EXACT_BENCHMARKS = ("micropolar_poiseuille", "micropolar_taylor_green")


def exact_for(scene):
    """The exact solution a scene's benchmark names, built from its parameters (None for the others)."""
    if scene.benchmark not in EXACT_BENCHMARKS:
        return None
    m, f = scene.micropolar, scene.fluid
    if scene.benchmark == "micropolar_poiseuille":
        return MicropolarPoiseuille(G=1.0, h=scene.geometry.height / 2, mu=f.mu, mu_r=m.mu_r,
                                    lambda1=m.lambda1, L=scene.geometry.length)
    return MicropolarTaylorGreen(rho=f.rho, inertia=m.inertia, mu=f.mu, mu_r=m.mu_r, lambda1=m.lambda1)
