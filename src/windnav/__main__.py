"""``python -m windnav``: the command line (:mod:`windnav.cli`)."""

import sys

from windnav.cli import main

sys.exit(main())
