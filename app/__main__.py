"""``python -m app``: the same as the ``sheer`` command."""

import sys

from app.cli import main

sys.exit(main())
