"""Behaviour regression set: short runs whose time series must not change under a refactoring.

    python campaigns/regression.py record [CASE ...]   # write tests/data/regression/dolfinx-<version>/<case>.csv
    python campaigns/regression.py check  [CASE ...]   # rerun and compare (exit 1 on a difference)

Each case is a short `cosserat-fsi run` (level 0 or the seed mesh, a few tens of steps, fields off) of a
shipped config; the set covers 2D-1, CFD3 with both characteristics schemes and with ale_bdf2 + a Picard pass, FSI3
first order, BDF2, ale_bdf2 and generalised-α + 2 passes, a Cosserat FSI3 (first order and generalised-α),
CSM1, micropolar Poiseuille, a restart and 2 MPI ranks (the steady shipped configs with their former time
stepping pinned: 2D-1, CSM1 and Poiseuille are now solved by Newton when run as shipped). ``check`` compares
every column of timeseries.csv with the recorded one: |a − b| <= RTOL · max|b| over the column (+ 1e-14), RTOL = 1e-10.
tests/test_regression.py runs ``check`` on a few cases in CI.
"""

from __future__ import annotations

import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from pinned_law import FSI3_VOLUME_CORRECTION, INCOMPRESSIBLE, as_set

ROOT = Path(__file__).resolve().parents[1]
DATA_ROOT = ROOT / "tests" / "data" / "regression"
RTOL = 1e-10

_FAST_FLOW = ["geometry.level=0", "time.dt=0.005", "time.t_end=0.1", "inflow.ramp_time=0.05",
              "output.fields=false", "output.checkpoint_every=0", "time.tolerance=null"]  # fixed steps
_HARMONIC = ["solid.mesh_motion.method=harmonic"]  # the records were made with the seed's mesh motion
_NO_TILT = ["inflow.asymmetry=0"]  # CFD3's records were made without the tilt of the inflow during the ramp
_CHARS = ["time.corrector_passes=null"]  # the characteristics, one solve a step (with the time.scheme that follows)
# the incompressible law of the records (the shipped CSM and FSI scenes carry the benchmarks' compressible one)
_INCOMPRESSIBLE = as_set(INCOMPRESSIBLE)
# the FSI3 scene of the records, short and on level 0
_FSI3 = _FAST_FLOW + _INCOMPRESSIBLE + as_set(FSI3_VOLUME_CORRECTION) + _HARMONIC
CASES = {
    "st2d1": ("configs/schaefer_turek_2d1.yaml",
              ["geometry.level=0", "time.scheme=characteristics1", "time.dt=0.01", "time.t_end=0.2",
               "output.fields=false"]),
    "cfd3-c1": ("configs/turek_hron_cfd3.yaml", _FAST_FLOW + _NO_TILT + _CHARS + ["time.scheme=characteristics1"]),
    "cfd3-c2": ("configs/turek_hron_cfd3.yaml", _FAST_FLOW + _NO_TILT + _CHARS + ["time.scheme=characteristics2"]),
    "fsi3-c1": ("configs/turek_hron_fsi3.yaml", _FSI3 + _CHARS + ["time.scheme=characteristics1"]),
    "fsi3-c2": ("configs/turek_hron_fsi3.yaml", _FSI3 + _CHARS + ["time.scheme=characteristics2"]),
    "cosserat-fsi3": ("configs/seed_cosserat_fsi3.yaml",
                      [o for o in _FAST_FLOW if not o.startswith("geometry.")] + _HARMONIC),
    "csm1": ("configs/turek_hron_csm1.yaml",
             ["geometry.level=0", "time.scheme=characteristics1", "time.dt=0.005", "time.t_end=0.1",
              "solid.gravity_ramp_time=0.05", "output.fields=false", "geometry.clamp=straight"]
             + _INCOMPRESSIBLE),  # (no fluid mesh: the mesh motion is not a key of this scene)
    "mp-poiseuille": ("configs/micropolar_poiseuille.yaml",
                      ["geometry.level=0", "time.scheme=characteristics2", "time.dt=10", "time.t_end=50",
                       "output.fields=false"]),
    # the nodal schemes: the shipped FSI3 (ale_bdf2) and CFD3 (ale_bdf2 + a Picard pass), generalised-α + 2 passes
    "fsi3-ale": ("configs/turek_hron_fsi3.yaml", _FSI3),
    "cfd3-ale-picard": ("configs/turek_hron_cfd3.yaml", _FAST_FLOW + _NO_TILT),
    "fsi3-ga": ("configs/turek_hron_fsi3.yaml", _FSI3 + ["time.scheme=generalized_alpha",
                                                                         "time.corrector_passes=2"]),
    "cosserat-fsi3-ga": ("configs/seed_cosserat_fsi3.yaml",
                         [o for o in _FAST_FLOW if not o.startswith("geometry.")] + _HARMONIC
                         + ["time.scheme=generalized_alpha"]),
    # fsi3-c2 in two legs: to t = 0.05 (step 10: the last step's checkpoint), then --restart to t = 0.1
    "restart": ("configs/turek_hron_fsi3.yaml", _FSI3 + _CHARS + ["time.scheme=characteristics2"]),
    "np2": ("configs/turek_hron_fsi3.yaml", _FSI3 + _CHARS + ["time.scheme=characteristics2"]),
}


def _mpirun() -> list[str]:
    here = Path(sys.executable).parent
    for exe in (here / "mpiexec", here / "mpirun", shutil.which("mpirun"), shutil.which("mpiexec")):
        if exe and os.access(str(exe), os.X_OK):
            text = subprocess.run([str(exe), "--version"], capture_output=True, text=True).stdout
            return [str(exe)] + (["--allow-run-as-root", "--oversubscribe"] if "Open MPI" in text else [])
    raise SystemExit("no MPI launcher found")


def _env() -> dict:
    drop = ("OMPI_COMM_WORLD", "OMPI_MCA_ess", "OMPI_MCA_orte", "PMIX_", "PMI_", "HYDRA_")
    env = {k: v for k, v in os.environ.items() if not k.startswith(drop)}
    env.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", PYTHONPATH=str(ROOT))
    env.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))
    return env


def _cli(config, sets, out, extra=(), ranks=1):
    cmd = ([*_mpirun(), "-n", str(ranks)] if ranks > 1 else []) + [
        sys.executable, "-m", "cosserat_fsi", "run", str(ROOT / config), "--out", str(out), "--no-progress",
        *[a for s in sets for a in ("--set", s)], *extra]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=_env(), cwd=ROOT, timeout=1800)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}\nexit {proc.returncode}\n{proc.stderr[-3000:]}")


def run_case(name: str, work: Path) -> Path:
    """Run one case into ``work/name``; returns its timeseries.csv."""
    config, sets = CASES[name]
    out = work / name
    if name == "restart":
        first = [s for s in sets if not s.startswith(("time.t_end", "output.checkpoint_every"))]
        first += ["time.t_end=0.05", "output.checkpoint_every=5"]  # checkpoints at steps 5 and 10 (the last)
        _cli(config, first, out)
        _cli(config, sets, out, extra=["--restart", str(out)])
    else:
        _cli(config, sets, out, ranks=2 if name == "np2" else 1)
    return out / "timeseries.csv"


def read(path: Path) -> dict[str, np.ndarray]:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def compare(new: dict, old: dict, rtol: float = RTOL) -> list[str]:
    """Differences between two time series, one line each (empty: identical to rtol)."""
    problems = []
    if set(new) != set(old):
        problems.append(f"columns differ: {sorted(set(new) ^ set(old))}")
    for key in sorted(set(new) & set(old)):
        a, b = new[key], old[key]
        if a.shape != b.shape:
            problems.append(f"{key}: {a.shape[0]} rows, recorded {b.shape[0]}")
            continue
        scale = np.abs(b).max(initial=0.0)
        err = np.abs(a - b).max(initial=0.0)
        if not err <= rtol * scale + 1e-14:
            problems.append(f"{key}: max |diff| {err:.3e} > {rtol:g} x {scale:.3e}")
    return problems


def largest(new: dict, old: dict) -> float:
    """The largest |a − b| / max|b| over the common columns (the number ``compare`` bounds)."""
    return max((np.abs(new[k] - old[k]).max(initial=0.0) / max(np.abs(old[k]).max(initial=0.0), 1e-300)
                for k in set(new) & set(old) if new[k].shape == old[k].shape), default=0.0)


def data_dir() -> Path:
    """tests/data/regression/dolfinx-<version>: each stack has its own record (they differ by round-off)."""
    code = "import cosserat_fsi.compat as c; print(c.dolfinx.__version__)"
    version = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(),
                             check=True).stdout.strip()
    return DATA_ROOT / f"dolfinx-{version}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("record", "check"))
    parser.add_argument("cases", nargs="*", help=f"default: all ({', '.join(CASES)})")
    parser.add_argument("--rtol", type=float, default=RTOL, help=f"relative tolerance (default {RTOL:g})")
    args = parser.parse_args(argv)
    names = args.cases or list(CASES)
    unknown = [n for n in names if n not in CASES]
    if unknown:
        parser.error(f"unknown case(s) {unknown}")
    data = data_dir()
    data.mkdir(parents=True, exist_ok=True)
    failed = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            series = run_case(name, Path(tmp))
            recorded = data / f"{name}.csv"
            if args.action == "record":
                shutil.copyfile(series, recorded)
                print(f"{name}: recorded {recorded.relative_to(ROOT)}")
                continue
            new, old = read(series), read(recorded)
            problems = compare(new, old, args.rtol)
            failed += bool(problems)
            print(f"{name}: " + (f"same to {args.rtol:g} (largest relative difference {largest(new, old):.1e})"
                                 if not problems else "DIFFERENT\n  " + "\n  ".join(problems)))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
