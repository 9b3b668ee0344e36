"""``python -m warpfree.bundle build|verify``: the same as ``warpfree bundle``."""

import sys

from .build import main

if __name__ == "__main__":
    sys.exit(main())
