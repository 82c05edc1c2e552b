"""``python -m spacerobot.system.sweep ...`` (same options as ``spacerobot sweep``)."""
import sys

from .cli import main

sys.exit(main())
