"""``python -m cosserat_fsi run|mesh|plot|study|info``: the same as the ``cosserat-fsi`` console script."""

import sys

try:  # Ctrl-C while the libraries are imported: the same one line as later, nothing written
    from cosserat_fsi.app.cli import main
except KeyboardInterrupt:
    print("interrupted: Ctrl-C (SIGINT); stopped before the time loop (no checkpoint)", file=sys.stderr, flush=True)
    sys.exit(130)

sys.exit(main())
