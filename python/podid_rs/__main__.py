"""``python -m podid_rs`` runs the ``podid-rs`` command line."""

import sys

from .apps.cli import main

sys.exit(main())
