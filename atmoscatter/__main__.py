"""``python -m atmoscatter`` runs the ``atmoscatter`` command."""

import sys

from .cli import main

sys.exit(main())
