"""``python -m sysid_core.cli``: the ``sysid`` program."""

import sys

from sysid_core.cli import main

sys.exit(main())
