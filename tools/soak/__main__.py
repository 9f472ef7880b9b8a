"""``python -m tools.soak``: see :mod:`tools.soak.run`."""

import sys

from tools.soak.run import main

sys.exit(main())
