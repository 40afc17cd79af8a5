"""Child process of ``build_msh``: ``python -m cosserat_fsi.geometry '{"name", "level", "params", "out"}'``
meshes one geometry with gmsh into ``out``. Exit 0 on success; on failure one line on stdout and exit 1."""

import json
import os
import signal
import sys

from . import _MODULES, _gmsh


def die_with_parent(parent: int | None) -> None:
    """End this process when the run that started it ends, even by SIGKILL: on Linux the kernel sends it
    SIGKILL when its parent dies (prctl PR_SET_PDEATHSIG); a parent that died before that was set is seen
    as a changed parent pid, and this process exits at once."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # 1: PR_SET_PDEATHSIG
        except (OSError, AttributeError):  # another C library: only the pid check below
            pass
    if parent is not None and os.getppid() != parent:
        os._exit(1)


def main(request: str) -> int:
    """Build the mesh the JSON ``request`` describes."""
    spec = json.loads(request)
    die_with_parent(spec.get("parent"))
    signal.signal(signal.SIGINT, signal.SIG_DFL)  # the parent cleans up; die at once
    module = _MODULES[spec["name"]]
    scale = module.SEED_SCALE if spec["level"] == "seed" else 2.0 ** -spec["level"]
    import gmsh

    from ..parallel import failpoint

    failpoint("gmsh")  # the fault suite: a gmsh that fails or dies
    try:
        gmsh.initialize(["gmsh", "-nopopup"], readConfigFiles=False)
        try:
            if spec["name"] == "file":  # a user's file: its own options, names checked and written beside
                names = module.build(gmsh, scale, spec["params"])
                gmsh.write(spec["out"])
                module.names_path(spec["out"]).write_text(json.dumps(names, sort_keys=True) + "\n")
            else:
                _gmsh.configure(gmsh)
                module.build(gmsh, scale, spec["params"])
                gmsh.write(spec["out"])
        finally:
            gmsh.finalize()
    except getattr(module, "_Refused", ()) as exc:  # bad input: one line for the parent, exit 2
        print(str(exc), flush=True)
        return 2
    except Exception as exc:  # noqa: BLE001 (reported to the parent as one line)
        print(f"{exc.__class__.__name__}: {' '.join(str(exc).split())}", flush=True)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
