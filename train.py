#!/usr/bin/env python
"""Train a PPO/SAC strategy: ``python train.py --help`` (see :mod:`hev_thermal_env.cli.train`)."""

import sys

try:
    from hev_thermal_env.cli.train import main
except KeyboardInterrupt:  # Ctrl-C while the package loads, before the program's own handler exists
    print("interrupted", file=sys.stderr)
    sys.exit(130)

if __name__ == "__main__":
    sys.exit(main())
