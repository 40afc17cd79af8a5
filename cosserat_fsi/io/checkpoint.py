"""Checkpoints: the full state of a Simulation, one .npz per rank, plus meta.json (rank 0).

``<run>/checkpoint/`` is replaced atomically (written to ``checkpoint.tmp`` and renamed), so a kill
while writing leaves the previous checkpoint intact. Each rank stores its owned dofs keyed by their
coordinates on the reference mesh, so a restart does not depend on the partition (dolfinx's is not
deterministic) and may even use another rank count; the scene must be the same up to ``time.t_end``
and ``output`` (checked by hash).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import numpy as np

from ..errors import InputError

FORMAT = 1


def scene_fingerprint(scene) -> str:
    """Hash of the scene without what a restart may change (t_end, output, name)."""
    data = scene.model_dump(mode="json")
    data.pop("output", None)
    data.pop("name", None)
    data.get("time", {}).pop("t_end", None)
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]


def write_checkpoint(run_dir: Path, sim, comm, meta: dict) -> None:
    """Write the state of every rank and ``meta`` (+ step, t, ranks) into run_dir/checkpoint."""
    final, tmp = run_dir / "checkpoint", run_dir / "checkpoint.tmp"
    if comm.rank == 0:
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir()
    comm.barrier()
    with open(tmp / f"rank{comm.rank:04d}.npz", "wb") as f:
        np.savez(f, **sim.checkpoint())
        f.flush()
        os.fsync(f.fileno())
    comm.barrier()
    if comm.rank == 0:
        meta = {"format": FORMAT, "ranks": comm.size, "step": sim.step_count, "t": sim.t, **meta}
        (tmp / "meta.json").write_text(json.dumps(meta, indent=2), encoding="utf-8")
        old = run_dir / "checkpoint.old"
        shutil.rmtree(old, ignore_errors=True)
        if final.exists():
            os.replace(final, old)
        os.replace(tmp, final)
        shutil.rmtree(old, ignore_errors=True)
    comm.barrier()


def read_checkpoint(run_dir: Path, comm, fingerprint: str) -> tuple[dict, list]:
    """(meta, the states of all ranks that wrote it); InputError naming --restart if it cannot be used."""
    folder = Path(run_dir) / "checkpoint"
    meta_path = folder / "meta.json"
    if not meta_path.exists():
        raise InputError(f"--restart: {run_dir} has no checkpoint (no {meta_path.name} in {folder})")
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"--restart: {meta_path} is not a checkpoint ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise InputError(f"--restart: {meta_path} is not a cosserat-fsi checkpoint (format {FORMAT})")
    if meta.get("fingerprint") != fingerprint:
        raise InputError("--restart: the checkpoint is from another scene (only time.t_end and output may "
                         "change on a restart)")
    states = []
    for rank in range(int(meta.get("ranks", 0))):
        path = folder / f"rank{rank:04d}.npz"
        try:
            with np.load(path) as data:
                states.append({k: data[k] for k in data.files})
        except (OSError, ValueError) as exc:
            raise InputError(f"--restart: cannot read {path} ({exc.__class__.__name__})") from None
    if not states:
        raise InputError(f"--restart: {meta_path} names no rank files")
    return meta, states
