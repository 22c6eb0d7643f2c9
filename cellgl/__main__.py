"""``python -m cellgl``: same as the ``cellgl`` command."""

import sys

from .cli import main

sys.exit(main())
