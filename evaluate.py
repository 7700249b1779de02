#!/usr/bin/env python
"""Evaluate strategies on the hybrid bus: ``python evaluate.py --help`` (see :mod:`hev_thermal_env.cli.evaluate`)."""

import sys

from hev_thermal_env.cli.evaluate import main

if __name__ == "__main__":
    sys.exit(main())
