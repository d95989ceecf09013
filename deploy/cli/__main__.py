"""``python -m deploy.cli`` = ``zenav`` (this checkout's code, whatever ``zenav`` on PATH is)."""

import sys

from deploy.cli import main

sys.exit(main())
