"""Sweep hyperparameters and seeds with Ray Tune: Optuna search, ASHA stopping, the best trial exported.

The program behind ``python -m tools.sweep``, run from the checkout's root, a thin layer over :mod:`.study`;
``--help`` shows the examples and the notes.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from hev_thermal_env.cli.errors import (
    EXIT_INTERRUPTED,
    USER_ERRORS,
    HelpFormatter,
    OneLineErrorParser,
    add_run_options,
    eval_cycles,
    examples,
    refuse_settings_with_resume,
    run_program,
)

PROG = "python -m tools.sweep"
EXAMPLES = (
    "python -m tools.sweep --out sweeps/ppo --samples 8 --seeds 3 --timesteps 2000000",
    "python -m tools.sweep --out sweeps/lr --space space.yaml --hp n_envs=16",
    "python -m tools.sweep --resume sweeps/ppo                   # continue an interrupted sweep",
    "python -m tools.sweep --out sweeps/ppo --address HEAD:6379  # on a cluster (ray start --head)",
)

NOTES = """\
needs the ray extra (pip install -e ".[ray]"); run from the checkout's root.

search space (--space FILE, YAML): --hp keys mapped to a sampler or a fixed value:
    learning_rate: {loguniform: [1.0e-4, 1.0e-3]}
    gamma: {uniform: [0.95, 0.99]}
    n_epochs: {int: [3, 10]}
    policy_kwargs.net_arch: {choice: [[64, 64], [128, 128]]}

(default: a small PPO or SAC space). A space with fixed values only is a multi-seed study of one
configuration. Every trial is a train.py run with a seed of its own (--seed, --seed + 1, ...) that
reports its validation return (mean over the evaluation cycles) at every evaluation, with a
checkpoint; ASHA (--scheduler) stops the trials that fall behind.

outputs in --out: sweep.yaml, tune/ (one folder per trial, its run in run/), sweep_trials.csv,
sweep_configs.csv/.md/.json (per configuration: IQM over seeds, 95 % bootstrap CI), sweep.png and
best_policy/ (load it with --strategy ppo:DIR/best_policy).

Ctrl-C stops the sweep after saving its state (exit status 130); --resume DIR continues it. On a
cluster, --out must be on storage that every node sees at the same path."""

# The training room (torch, Stable-Baselines3) and Ray are imported inside the functions that need them, so that
# a Ctrl-C while they load is reported in one line like any other.


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    p = OneLineErrorParser(prog=prog, description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter,
                           epilog=examples(EXAMPLES) + "\n\n" + NOTES)
    add_run_options(p)
    p.add_argument("--out", default=None, help="sweep directory (new or empty)")
    p.add_argument("--resume", default=None, metavar="DIR", help="continue the interrupted sweep in DIR")
    p.add_argument("--space", default=None, metavar="FILE", help="search space (YAML; default: a small space)")
    p.add_argument("--samples", type=int, default=None, help="configurations Optuna draws (default 8)")
    p.add_argument("--seeds", type=int, default=None, help="trials (seeds) per configuration (default 3)")
    p.add_argument("--seed", type=int, default=None, help="first seed, and Optuna's (default 0)")
    p.add_argument("--scheduler", default=None, help="asha (default), median or none: early stopping")
    p.add_argument("--grace", type=int, default=None, metavar="STEPS",
                   help="env-steps before a trial can be stopped (default: two evaluations)")
    p.add_argument("--max-concurrent", type=int, default=None, help="trials at once (default: one per CPU)")
    p.add_argument("--address", default=None, metavar="ADDR", help="join the Ray cluster at HOST:PORT")
    p.add_argument("--cpus", type=int, default=None, help="CPUs of the local Ray runtime (default: all)")
    p.add_argument("--export", default=None, metavar="DIR", help="where the best policy goes (default DIR/best_policy)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def sweep(args: argparse.Namespace, command: str):
    """Start or resume the sweep that ``args`` describe; returns its report and directory."""
    from hev_thermal_env.evaluation.executors import import_ray

    import_ray()
    from hev_thermal_env.training import parse_overrides

    from .study import build_sweep, resume_sweep, run_sweep

    common = dict(address=args.address, num_cpus=args.cpus, progress=not args.no_progress, export=args.export)
    if args.cpus is not None and args.cpus < 1:
        raise ValueError(f"--cpus must be at least 1, got {args.cpus}")
    if args.resume is not None:
        refuse_settings_with_resume(args, "sweep.yaml")
        return resume_sweep(args.resume, **common), args.resume
    if args.out is None:
        raise ValueError("--out DIR is required (or --resume DIR)")
    train = dict(cycles=args.cycles, scenario=args.scenario, timesteps=args.timesteps, n_envs=args.n_envs,
                 eval_cycles=eval_cycles(args), eval_scenarios=args.eval_scenarios, eval_freq=args.eval_freq)
    settings = build_sweep(
        args.algo or "ppo", space_file=args.space, samples=8 if args.samples is None else args.samples,
        seeds=3 if args.seeds is None else args.seeds, seed=args.seed or 0, scheduler=args.scheduler or "asha",
        grace_timesteps=args.grace, max_concurrent=args.max_concurrent, hyperparams_file=args.hyperparams,
        overrides=parse_overrides(args.hp or []), train=train, command=command)
    return run_sweep(settings, args.out, **common), args.out


def main(argv: list[str] | None = None) -> int:
    """Ray Tune over hyperparameters and seeds as ``argv`` (default: the command line) say; the exit status."""
    given = list(sys.argv[1:] if argv is None else argv)
    command = " ".join([PROG, *map(shlex.quote, given)])

    from hev_thermal_env.evaluation.executors import ExecutorError

    def body() -> int:
        report, out = sweep(build_parser().parse_args(given), command)
        return report_outcome(report, out)

    return run_program(body, PROG, (*USER_ERRORS, ExecutorError))


def report_outcome(report, out: str) -> int:
    """Print the sweep's table (a :class:`~tools.sweep.report.SweepReport`) and where its files are; returns the exit
    status."""
    print((Path(out) / "sweep_configs.md").read_text())
    failed = sum(t.status == "error" for t in report.trials)
    if failed:
        print(f"{failed} of {len(report.trials)} trials failed; see error.txt in their folders under {out}/tune")
    if not report.complete:
        print(f"interrupted: {sum(t.status in ('finished', 'stopped') for t in report.trials)} trials done; "
              f"continue with: {PROG} --resume {out}", file=sys.stderr)
        return EXIT_INTERRUPTED
    stopped = sum(t.status == "stopped" for t in report.trials)
    print(f"{len(report.trials)} trials ({stopped} stopped early); tables and plot in {out} "
          f"(sweep_configs.md, sweep_trials.csv, sweep.png)")
    if report.exported is not None:
        print(f"best trial {report.best.trial_id} exported to {report.exported}: "
              f"evaluate.py run --strategy ppo:{report.exported}")
    return 0 if report.best is not None else 1
