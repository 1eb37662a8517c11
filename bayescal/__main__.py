"""``python -m bayescal``: the same as the ``bayescal`` command."""
import sys

from .cli import main

sys.exit(main())
