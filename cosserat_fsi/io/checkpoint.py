"""Checkpoints: the full state of a Simulation, one .npz per rank, plus meta.json (rank 0).

``<run>/checkpoint/`` is replaced atomically (written to ``checkpoint.tmp`` and renamed), so a kill
while writing leaves the previous checkpoint intact. Each rank stores its owned dofs keyed by their
coordinates on the reference mesh, so a restart does not depend on the partition (dolfinx's is not
deterministic) and may even use another rank count; the scene must be the same up to ``time.t_end``
and ``output`` (checked by hash).
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import shutil
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..files import open_regular
from .safe_yaml import read_text_file

FORMAT = 1


def scene_fingerprint(scene) -> str:
    """Hash of the scene without what a restart may change (t_end, output, name, reference); a user's mesh
    file counts by its content (and that of the files it includes), not by its path."""
    data = scene.model_dump(mode="json")
    data.pop("output", None)
    data.pop("name", None)
    data.pop("reference", None)
    if isinstance(data.get("observables"), dict) and not data["observables"].get("lines"):
        data["observables"].pop("lines", None)  # no profiles: the hash of a scene written before they existed
    data.get("time", {}).pop("t_end", None)
    if data.get("geometry", {}).get("name") == "file":  # the mesh file by content, not by where it is
        data["geometry"]["path"] = scene.geometry.content_digest()
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]


def mesh_digest(path: Path) -> str:
    """SHA-256 of a mesh file (a remeshed run records it with the mesh, a restart compares it)."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _msh_cells(path: Path, dim: int) -> int:
    """The number of ``dim``-cells of a .msh file (gmsh; InputError naming it if gmsh cannot read it)."""
    import gmsh

    gmsh.initialize(["-nopopup"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.merge(str(path))
        return sum(len(tags) for tags in gmsh.model.mesh.getElements(dim)[1])
    except Exception:  # noqa: BLE001 (gmsh raises a bare Exception on a damaged file)
        raise InputError(f"{path}: cannot be read as a mesh (damaged or cut short)") from None
    finally:
        gmsh.finalize()


def read_checkpoint_mesh(run_dir: Path, meta: dict, comm, gdim: int):
    """(mesh, cell_tags, facet_tags) of the remeshed mesh a checkpoint is on (``meta['mesh']``), checked on
    rank 0 before it is read: present, and the one the checkpoint was written on: its SHA-256 that the
    remesh record holds, or (a record without it) its cell count. InputError naming the file otherwise."""
    from .. import compat
    from ..parallel import on_root

    name = meta["mesh"]
    if not isinstance(name, str) or not name.startswith("meshes/") or "/" in name[len("meshes/"):]:
        raise InputError(f"--restart: {Path(run_dir) / 'checkpoint' / 'meta.json'} names a bad mesh ({str(name)[:60]})")
    path = Path(run_dir) / name
    records = [r for r in meta.get("remeshes") or [] if isinstance(r, dict) and r.get("mesh") == path.name]
    record = records[-1] if records else {}

    def check():
        if not path.is_file():
            raise InputError(f"{path}: the checkpoint's mesh is {'missing' if not path.exists() else 'not a file'}")
        if isinstance(record.get("sha256"), str):
            if mesh_digest(path) != record["sha256"]:
                raise InputError(f"{path}: is not the mesh the checkpoint was written on (changed since: cut "
                                 "short or replaced)")
            return
        cells = _msh_cells(path, gdim)
        if isinstance(record.get("cells"), int) and cells != record["cells"]:
            raise InputError(f"{path}: has {cells} cells, the checkpoint's mesh {record['cells']} (another mesh)")

    on_root(comm, check, step="checkpoint.mesh")
    return compat.read_msh(path, comm, gdim=gdim)


def write_checkpoint(run_dir: Path, sim, comm, meta: dict) -> None:
    """Write the state of every rank and ``meta`` (+ step, t, ranks) into run_dir/checkpoint.

    Collective; a failure on any rank (disk full) is raised on every rank (``parallel``), and the
    previous checkpoint is then kept as it was."""
    from ..parallel import agree, failpoint, on_root
    from .runfolder import atomic_write_text, output_error

    final, tmp = run_dir / "checkpoint", run_dir / "checkpoint.tmp"

    def start():
        shutil.rmtree(tmp, ignore_errors=True)
        try:
            tmp.mkdir()
        except OSError as exc:
            raise output_error(tmp, exc) from None

    def write_rank():
        path = tmp / f"rank{comm.rank:04d}.npz"
        try:
            failpoint("checkpoint.rank")
            data = io.BytesIO()  # the archive is made in memory: a full disk fails the write below only
            np.savez(data, **sim.checkpoint())
            with open(path, "wb") as f:
                f.write(data.getbuffer())
                f.flush()
                os.fsync(f.fileno())
        except OSError as exc:
            raise output_error(path, exc) from None

    def finish():
        full = {"format": FORMAT, "ranks": comm.size, "step": sim.step_count, "t": sim.t, **meta}
        atomic_write_text(tmp / "meta.json", json.dumps(full, indent=2))
        old = run_dir / "checkpoint.old"
        try:
            shutil.rmtree(old, ignore_errors=True)
            if final.exists():
                os.replace(final, old)
            os.replace(tmp, final)
        except OSError as exc:
            raise output_error(final, exc) from None
        shutil.rmtree(old, ignore_errors=True)

    try:
        on_root(comm, start, step="checkpoint")
        agree(comm, write_rank)
        on_root(comm, finish, step="checkpoint.meta")
    except BaseException:
        if comm.rank == 0:
            shutil.rmtree(tmp, ignore_errors=True)
        raise


def _meta_problem(meta) -> str | None:
    """What is wrong with a parsed meta.json (types and ranges), or None."""
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        return f"is not a cosserat-fsi checkpoint (format {FORMAT})"
    rules = {"ranks": (int, 1, 1 << 20), "step": (int, 0, 1 << 40), "rows": (int, 0, 1 << 40),
             "field_steps": (int, 0, 1 << 40), "t": ((int, float), 0.0, math.inf)}
    for key, (kind, lo, hi) in rules.items():
        value = meta.get(key)
        if isinstance(value, bool) or not isinstance(value, kind) or not (lo <= value < hi):
            return f"has a bad {key!r} ({str(value)[:40]})"
    if not isinstance(meta.get("fingerprint"), str):
        return "has no scene fingerprint"
    if meta["rows"] != meta["step"]:
        return f"has {meta['rows']} rows for step {meta['step']}"
    return None


def read_checkpoint(run_dir: Path, comm, fingerprint: str) -> tuple[dict, list]:
    """(meta, the states of all ranks that wrote it); InputError naming --restart if it cannot be used."""
    folder = Path(run_dir) / "checkpoint"
    meta_path = folder / "meta.json"
    if not meta_path.is_file():
        raise InputError(f"--restart: {run_dir} has no checkpoint (no {meta_path.name} in {folder})")
    try:
        meta = json.loads(read_text_file(meta_path, "checkpoint file", 1 << 16))
    except ValueError as exc:
        raise InputError(f"--restart: {meta_path} is not a checkpoint ({str(exc)[:80]})") from None
    except InputError as exc:
        raise InputError(f"--restart: {exc}") from None
    problem = _meta_problem(meta)
    if problem:
        raise InputError(f"--restart: {meta_path} {problem}")
    if meta.get("fingerprint") != fingerprint:
        raise InputError("--restart: the checkpoint is from another scene (only time.t_end and output may "
                         "change on a restart)")
    states = []
    for rank in range(meta["ranks"]):
        path = folder / f"rank{rank:04d}.npz"
        try:
            f = open_regular(path, "checkpoint file")  # a FIFO would block: refused without reading
        except InputError as exc:
            raise InputError(f"--restart: cannot read {path} ({str(exc).rsplit(': ', 1)[-1]})") from None
        try:
            with f, np.load(f, allow_pickle=False) as data:
                states.append({k: data[k] for k in data.files})
        except Exception as exc:  # noqa: BLE001 (zip, pickle, value errors: a damaged file)
            raise InputError(f"--restart: cannot read {path} ({exc.__class__.__name__})") from None
    _check_states(states, meta, folder)
    return meta, states


def _check_states(states: list[dict], meta: dict, folder: Path) -> None:
    """Same keys on every rank, numeric finite arrays, matching .x/.v lengths, the step and time of meta."""
    keys = set(states[0])
    for rank, state in enumerate(states):
        where = folder / f"rank{rank:04d}.npz"
        if set(state) != keys or not {"t", "step_count"} <= keys:
            raise InputError(f"--restart: {where} does not match the other rank files")
        for key, a in state.items():
            if a.dtype.kind not in "fiu" or not np.isfinite(a).all():
                raise InputError(f"--restart: {where}: {key} is not finite numbers")
        for key in keys:
            if key.endswith(".x"):
                v = state.get(key[:-2] + ".v")
                if v is None or len(v) != len(state[key]) or state[key].ndim != 2:
                    raise InputError(f"--restart: {where}: {key[:-2]} has inconsistent sizes")
        if state["t"].shape != () or state["step_count"].shape != () or int(state["step_count"]) != meta["step"] \
                or abs(float(state["t"]) - meta["t"]) > 1e-9 * max(1.0, abs(meta["t"])):
            raise InputError(f"--restart: {where} is of another step than {folder / 'meta.json'}")


def check_restart_files(run_dir: Path, meta: dict, t_end: float, columns: list[str] | None,
                        fields: bool) -> None:
    """Rank 0, before anything is written: the folder can continue the checkpoint ``meta``.

    ``t_end`` at or after the checkpoint's time; timeseries.csv has the header ``t,<columns>`` (any
    columns if None) and at least ``meta['rows']`` complete numeric rows; fields.xdmf/fields.h5 list at
    least ``meta['field_steps']`` steps and no other program holds fields.h5 (when ``fields`` is on, or
    when there are earlier steps). InputError naming the file otherwise."""
    from .runfolder import file_in_use
    from .timeseries import check_timeseries

    if t_end < meta["t"] - 1e-9 * max(1.0, meta["t"]):
        raise InputError(f"time.t_end: {t_end!r} is before the checkpoint's time {meta['t']!r} "
                         "(a restart cannot go back)")
    check_timeseries(Path(run_dir) / "timeseries.csv", meta["rows"], columns, "--restart: ")
    xdmf, h5 = Path(run_dir) / "fields.xdmf", Path(run_dir) / "fields.h5"
    need = meta["field_steps"]
    if not fields and need == 0:
        return
    if need == 0 and not xdmf.exists() and not h5.exists():
        return
    from .fields_check import check_fields

    check_fields(xdmf, h5, need, "--restart: ")
    if fields and file_in_use(h5):
        raise InputError(f"--restart: {h5} is open in another program (ParaView? plot?); close it first")
