"""``python -m mjcable``: the ``mjcable`` command line (see :mod:`mjcable.cli`)."""

import sys

from mjcable.cli import main

sys.exit(main())
