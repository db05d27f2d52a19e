"""``python -m atmoscatter`` runs the ``atmoscatter`` command."""

from .cli import run

run()
