"""Kept so that ``python -m cosserat_fsi.cli`` and console scripts installed before the move still work; the
command line lives in cosserat_fsi/app/cli.py."""
from cosserat_fsi.app.cli import main

if __name__ == "__main__":
    import sys
    sys.exit(main())
