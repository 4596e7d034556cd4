"""``python -m mutual.cli``: the same as the ``mutual`` console script."""

import sys

from . import main

sys.exit(main())
