"""``python -m aceval``: the command line (:mod:`aceval.cli`)."""

import sys

try:
    from aceval.cli import main
except KeyboardInterrupt:  # Ctrl-C while the command line loads: nothing was started
    print("aceval: interrupted (Ctrl-C); no output written", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
