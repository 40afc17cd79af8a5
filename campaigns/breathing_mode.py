"""A compressible flag's breathing mode, measured on a run folder with fields written at every step.

    python campaigns/breathing_mode.py RUN_DIR [--from T0] [--to T1]

Prints, for each written step in [T0, T1]: the solid's area against its reference area (from the cells of
fields.h5 on the moved mesh), the outlet's flow rate (timeseries.csv) and the pressure at B (0.15, 0.2);
then the half-periods of the flow rate's oscillation about a quadratic trend (its zero crossings) and the
lumped model's frequency f = sqrt(K H / (V rho_f L)) / 2 pi for the heavy, soft flag of
configs/turek_hron_fsi3_heavy_soft.yaml with the quadratic displacement (docs/perf_adaptive_step.md,
"Large deformation with a compressible flag"). Serial output of a serial run (fields.h5 of one rank's mesh
order is enough for areas).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cosserat_fsi.io import read_timeseries  # noqa: E402
from cosserat_fsi.io.fields_check import xdmf_times  # noqa: E402

B = (0.15, 0.2)


def _areas(x: np.ndarray, cells: np.ndarray) -> np.ndarray:
    a, b, c = x[cells[:, 0]], x[cells[:, 1]], x[cells[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def lumped_frequency(lambda_s=2.0e6, mu_s=5.0e5, area=0.351 * 0.02, rho_f=1000.0, length=2.05, height=0.41):
    """The flag's area stiffness (λ_s + μ_s)/V against the fluid column's inertia ρ_f L/H (Hz)."""
    return math.sqrt((lambda_s + mu_s) * height / (area * rho_f * length)) / (2 * math.pi)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--from", dest="t0", type=float, default=0.0)
    parser.add_argument("--to", dest="t1", type=float, default=math.inf)
    args = parser.parse_args()
    times = xdmf_times(args.run / "fields.xdmf")
    series = read_timeseries(args.run / "timeseries.csv")
    with h5py.File(args.run / "fields.h5", "r") as f:
        cells = f["mesh/topology"][:]
        steps = sorted(f["mesh/geometry"].keys())
        solid = f["cell/subdomain"][steps[0]][:] == f["cell/subdomain"][steps[0]][:].max()
        reference = _areas(f["mesh/geometry"][steps[0]][:], cells)[solid].sum()
        for step, t in zip(steps, times):
            if not args.t0 <= t <= args.t1:
                continue
            x = f["mesh/geometry"][step][:]
            area = _areas(x, cells)[solid].sum()
            i = int(np.argmin(np.abs(series["t"] - t)))
            b = int(np.argmin(np.hypot(x[:, 0] - B[0], x[:, 1] - B[1])))
            print(f"t = {t:.5f}  solid area {1e6 * (area - reference):+.2f} mm²  "
                  f"flow rate {series['flow_rate'][i]:.5f} m²/s  p(B) {f['point/pressure'][step][b]:.0f} Pa")
    t, q = series["t"], series["flow_rate"]
    window = (t >= args.t0) & (t <= args.t1)
    t, q = t[window], q[window]
    y = q - np.polyval(np.polyfit(t, q, 2), t)
    crossings = t[:-1][np.sign(y[:-1]) != np.sign(y[1:])]
    half = np.diff(crossings)
    print(f"flow rate half-periods (s): {np.round(half, 4).tolist()}"
          + (f"; median {np.median(half):.4f} s = {0.5 / np.median(half):.1f} Hz" if len(half) else ""))
    print(f"lumped model: {lumped_frequency():.1f} Hz")


if __name__ == "__main__":
    main()
