"""``python -m aceval``: the command line (:mod:`aceval.cli`)."""

import sys

from aceval.cli import main

sys.exit(main())
