"""``python -m tools.sweep``: :mod:`tools.sweep.cli`."""

import sys

try:
    from tools.sweep.cli import main
except KeyboardInterrupt:  # Ctrl-C while the package loads, before the program's own handler exists
    print("interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
