"""``python3 -m eaplan_drake ...`` is the ``eaplan-drake`` command line."""

import sys

from eaplan_drake.cli import main

sys.exit(main())
