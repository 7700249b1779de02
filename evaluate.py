#!/usr/bin/env python
"""Evaluate strategies on the hybrid bus: ``python evaluate.py --help`` (see :mod:`hev_thermal_env.cli.evaluate`)."""

import sys

try:
    from hev_thermal_env.cli.evaluate import main
except KeyboardInterrupt:  # Ctrl-C while the package loads, before the program's own handler exists
    print("interrupted", file=sys.stderr)
    sys.exit(130)

if __name__ == "__main__":
    sys.exit(main())
