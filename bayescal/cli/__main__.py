"""``python -m bayescal.cli``: the same as the ``bayescal`` command."""
import sys

from . import main

sys.exit(main())
