"""`python -m depsim` runs the command line."""

import sys

from depsim.cli import main

sys.exit(main())
