#!/usr/bin/env python
"""Train a PPO/SAC strategy: ``python train.py --help`` (see :mod:`hev_thermal_env.cli.train`)."""

import sys

from hev_thermal_env.cli.train import main

if __name__ == "__main__":
    sys.exit(main())
