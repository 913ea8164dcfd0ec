"""``python -m robocourse.cli``: the same as the ``robocourse`` console script."""

import sys

from . import main

sys.exit(main())
