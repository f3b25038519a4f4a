"""`python3 -m urb`: the same as the `urb` command."""

import sys

from .cli import main

sys.exit(main())
