#!/usr/bin/env python
"""Long fuzz run of the environment's invariants (see ``tools.fuzz.fuzz``); writes JSON."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the checkout: its workshop, tools/

from tools.fuzz import fuzz  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--num-envs", type=int, default=256)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default="benchmarks/results/fuzz.json")
    args = ap.parse_args()
    report = fuzz(args.steps, num_envs=args.num_envs, seed=args.seed, progress=True)
    report["passed"] = True  # fuzz raises on the first violation
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(report, indent=2, default=float) + "\n")
    print(f"{report['steps']:,} steps, {report['episodes']} episodes, no violation; max energy-balance error "
          f"{report['max_balance_error']:.2e}; SOC {report['soc_min']:.3f}..{report['soc_max']:.3f}; "
          f"max motor temperature {report['temp_max_c']:.1f} °C; cutoff steps {report['cutoff_steps']}; "
          f"{report['wall_s']:.1f} s")
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
