"""``python -m mjcable.bench``: see :func:`mjcable.bench.main`."""

import sys

from mjcable.bench import main

sys.exit(main())
