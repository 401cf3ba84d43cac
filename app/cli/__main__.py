"""`python -m app.cli` runs the `artro` command (as the installed script does)."""

import sys

from app.cli import main

sys.exit(main())
