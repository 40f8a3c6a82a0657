"""``python -m crowdmotion``: the ``crowdmotion`` command (where the script is not on PATH)."""

import sys

from crowdmotion.cli import main

sys.exit(main())
