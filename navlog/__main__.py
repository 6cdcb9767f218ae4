"""``python -m navlog``: the same as the ``navlog`` command."""

import sys

from navlog.cli import main

sys.exit(main())
