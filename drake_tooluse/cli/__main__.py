"""`python -m drake_tooluse.cli`: the same as `drake-tooluse`."""

import sys

from drake_tooluse.cli import main

sys.exit(main())
