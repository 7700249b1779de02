"""Sweep hyperparameters and seeds with Ray Tune: Optuna search, ASHA stopping, the best trial exported.

``train.py sweep`` (or ``train.py --sweep``); needs the ``ray`` extra.

Examples::

    python train.py sweep --out sweeps/ppo --samples 8 --seeds 3 --timesteps 2000000
    python train.py sweep --out sweeps/lr --space space.yaml --hp n_envs=16
    python train.py sweep --resume sweeps/ppo                  # continue an interrupted sweep
    python train.py sweep --out sweeps/ppo --address HEAD:6379 # on a cluster (ray start --head)

The search space (``--space FILE``, YAML) maps ``--hp`` keys to a sampler or a fixed value::

    learning_rate: {loguniform: [1.0e-4, 1.0e-3]}
    gamma: {uniform: [0.95, 0.99]}
    n_epochs: {int: [3, 10]}
    policy_kwargs.net_arch: {choice: [[64, 64], [128, 128]]}

(default: a small PPO or SAC space). A space with fixed values only is a multi-seed study of one
configuration. Every trial is a train.py run with a seed of its own (``--seed``, ``--seed`` + 1, ...)
that reports its validation return (mean over the evaluation cycles) at every evaluation, with a
checkpoint; ASHA (``--scheduler``) stops the trials that fall behind. The sweep directory gets
``sweep.yaml``, ``tune/`` (one folder per trial, its run in ``run/``), ``sweep_trials.csv``,
``sweep_configs.csv``/``.md``/``.json`` (per configuration: IQM over seeds, 95 % bootstrap CI),
``sweep.png`` and ``best_policy/`` (load it with ``--strategy ppo:DIR/best_policy``).

Ctrl-C stops the sweep after saving its state (exit status 130); ``--resume DIR`` continues it.
On a cluster, ``--out`` must be on storage that every node sees at the same path.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hev_thermal_env.evaluation.executors import ExecutorError, import_ray

from .errors import EXIT_INTERRUPTED, USER_ERRORS, run_program
from .parsing import OneLineErrorParser, add_run_options, eval_cycles, refuse_settings_with_resume


def build_parser(prog: str) -> argparse.ArgumentParser:
    p = OneLineErrorParser(prog=prog, description=__doc__.split("\n\n")[0],
                           formatter_class=argparse.RawDescriptionHelpFormatter,
                           epilog="\n\n".join(__doc__.split("\n\n")[1:]))
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


def run(args: argparse.Namespace, command: str):
    """Start or resume the sweep that ``args`` describe; returns its report and directory."""
    import_ray()
    from hev_thermal_env.training import parse_overrides
    from hev_thermal_env.training.sweep import build_sweep, resume_sweep, run_sweep

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


def main(argv: list[str], prog: str = "train.py sweep", command: str | None = None) -> int:
    def body() -> int:
        report, out = run(build_parser(prog).parse_args(argv), command or prog)
        return report_outcome(report, out, prog)

    return run_program(body, prog, (*USER_ERRORS, ExecutorError))


def report_outcome(report, out: str, prog: str) -> int:
    """Print the sweep's table (a :class:`~hev_thermal_env.training.sweep.SweepReport`) and where its files
    are; returns the exit status."""
    print((Path(out) / "sweep_configs.md").read_text())
    failed = sum(t.status == "error" for t in report.trials)
    if failed:
        print(f"{failed} of {len(report.trials)} trials failed; see error.txt in their folders under {out}/tune")
    if not report.complete:
        print(f"interrupted: {sum(t.status in ('finished', 'stopped') for t in report.trials)} trials done; "
              f"continue with: {prog} --resume {out}", file=sys.stderr)
        return EXIT_INTERRUPTED
    stopped = sum(t.status == "stopped" for t in report.trials)
    print(f"{len(report.trials)} trials ({stopped} stopped early); tables and plot in {out} "
          f"(sweep_configs.md, sweep_trials.csv, sweep.png)")
    if report.exported is not None:
        print(f"best trial {report.best.trial_id} exported to {report.exported}: "
              f"evaluate.py run --strategy ppo:{report.exported}")
    return 0 if report.best is not None else 1
