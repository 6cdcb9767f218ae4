import sys

from navlog.cli import main

sys.exit(main())
