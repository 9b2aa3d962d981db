"""``python -m aceval``: the command line (:mod:`aceval.cli`)."""

import sys

from .cli import main

sys.exit(main())
