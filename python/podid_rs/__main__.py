"""``python -m podid_rs`` runs the ``podid-rs`` command line."""

import sys

from .cli import main

sys.exit(main())
