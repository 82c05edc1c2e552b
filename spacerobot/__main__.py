"""``python -m spacerobot ...``: the ``spacerobot`` command line."""
import sys

from .system.cli import main

sys.exit(main())
