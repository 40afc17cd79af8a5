"""Kept so that ``python -m cosserat_fsi.cli`` still works; the command line lives in cosserat_fsi/app/cli.py."""
if __name__ == "__main__":
    import sys

    from cosserat_fsi.app.cli import main
    sys.exit(main())
