"""Observables of a run: forces on the body, point probes, derived benchmark coefficients.

Every value is parallel-correct: integrals are summed over ranks, probes are evaluated by the rank that
owns the point.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from . import compat
from .physics.stress import body_traction, cauchy_stress
from .scheme.characteristics import probe
from .scheme.stepper import TAGS

import dolfinx
import ufl

# Schäfer–Turek pressure probes: front and back of the cylinder (shared/reference/benchmarks.yaml)
DP_POINTS = np.array([[0.15, 0.2, 0.0], [0.25, 0.2, 0.0]])
BODY = ("cylinder", "interface")


class Observables:
    """Evaluates the observables of a scene from the stepper's current state."""

    def __init__(self, stepper):
        self.stepper = stepper
        self.comm = stepper.comm
        scene = stepper.scene
        mesh = stepper.mesh
        ft = stepper.facet_tags
        sp = stepper.space
        parts = ufl.split(stepper.w)
        u, p = parts[sp.index("velocity")], parts[sp.index("pressure")]
        omega = parts[sp.index("micro_rotation")] if stepper.model.micro_rotation else None
        mu_r = stepper.mu_r if stepper.model.micro_rotation else None
        T = cauchy_stress(u, p, stepper.mu, mu_r, omega)
        n = ufl.FacetNormal(mesh)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=ft)
        body_tags = tuple(TAGS[b] for b in BODY
                          if self.comm.allreduce(int(np.any(ft.values == TAGS[b])), op=MPI.MAX))
        self.columns = []
        self._force_forms = None
        if body_tags:
            traction = body_traction(T, n)
            ds_body = ds(body_tags)
            self._force_forms = [compat.form(traction[i] * ds_body) for i in range(2)]
            self.columns += ["drag", "lift"]
        self._dp = scene.geometry.name == "schaefer_turek"
        if self._dp:
            self.columns.append("dp")
        if stepper.model.micro_rotation:
            self.columns.append("omega_max")

    def evaluate(self) -> dict:
        out = {}
        if self._force_forms is not None:
            drag, lift = (self.comm.allreduce(dolfinx.fem.assemble_scalar(f), op=MPI.SUM)
                          for f in self._force_forms)
            out["drag"], out["lift"] = drag, lift
        if self._dp:
            st = self.stepper
            p = probe(st.chars.locator, [st.p_n], DP_POINTS, self.comm)[0][:, 0]
            out["dp"] = float(p[0] - p[1])
        if self.stepper.model.micro_rotation:
            local = np.abs(self.stepper.omega_n.x.array).max(initial=0.0)
            out["omega_max"] = self.comm.allreduce(local, op=MPI.MAX)
        return out


def schaefer_turek_coefficients(drag: float, lift: float, rho: float, u_mean: float, diameter: float = 0.1):
    """c_D = 2 F_D / (ρ Ū² D), c_L = 2 F_L / (ρ Ū² D) (Schäfer & Turek 1996)."""
    scale = 2.0 / (rho * u_mean**2 * diameter)
    return drag * scale, lift * scale
