"""``python -m cellgl``: same as the ``cellgl`` command."""

import sys

from cellgl.cli import main

sys.exit(main())
