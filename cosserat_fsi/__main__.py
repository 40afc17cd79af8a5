"""``python -m cosserat_fsi run|mesh|plot|study|info``: the same as the ``cosserat-fsi`` console script."""

import sys

from cosserat_fsi.app.cli import main

sys.exit(main())
