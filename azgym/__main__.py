"""``python -m azgym``: the ``azgym`` command."""

import sys

from azgym.cli import main

sys.exit(main())
