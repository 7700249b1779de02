"""Train an SB3 agent (PPO, SAC, TQC, RecurrentPPO or PPO-Lagrangian) as the energy-management strategy of the bus.

The program behind ``train.py`` and ``hev-train``, a thin layer over :mod:`hev_thermal_env.training`;
``--help`` shows the examples, the notes and every default (from the hyperparameter files).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from hev_thermal_env.tasks import list_tasks

from .errors import (
    EXIT_INTERRUPTED,
    USER_ERRORS,
    HelpFormatter,
    OneLineErrorParser,
    add_run_options,
    eval_cycles,
    examples,
    per_algo,
    program_name,
    refuse_settings_with_resume,
    run_program,
)

# The training room (torch, Stable-Baselines3) is imported inside the functions that need it, so that
# a Ctrl-C while it loads is reported in one line like any other.

EXAMPLES = (
    "python train.py --algo ppo --cycles bus_long bus_congested bus_mixed --scenario random_service \\",
    "    --timesteps 5000000 --eval-cycles validation_bus:0..4 --eval-scenarios paper full_bus \\",
    "    --n-envs 32 --seed 0 --out runs/ppo_s0",
    "python train.py --algo ppo --hp gamma=0.99 'policy_kwargs={net_arch: [128, 128]}' --out runs/ppo_wide",
    "python train.py --algo sac --hp learning_rate=lin_3e-4 env.reward.soc_deviation_weight=10 --out runs/sac",
    "python train.py --task bus-generalisation --seed 1 --out runs/gen_s1   # the task's training cycles and scenario",
    "python train.py --resume runs/ppo_s0                 # continue an interrupted run to its total",
    "python evaluate.py run --cycle beijing --strategy ppo:runs/ppo_s0   # drive a trained run",
)

NOTES = """\
hyperparameters: agents/hyperparams/<algo>.yaml (or --hyperparams FILE); --hp key=value overrides
any of them. Values are YAML: 0.99, [64, 64], {net_arch: [64, 64], activation_fn: tanh}, lin_3e-4
(a linear decay); dotted keys reach inside mappings (policy_kwargs.net_arch=[64,64],
env.reward.soc_deviation_weight=1.0).

selection: best_model.zip is the checkpoint with the best eval.selection score on the evaluation
cycles (default fuel_vs_ecms: lowest mean corrected fuel / ECMS, |dSOC| > 0.02 disqualifies); at the
end the best and final models are scored on eval.final_cycles (validation.csv).

outputs in --out: model.zip, best_model.zip, vecnormalize.pkl, config.yaml, command.txt,
checkpoints/, tb/ (TensorBoard), evaluations.csv, validation.csv, training_curve.png.

algorithms: ppo, sac (Stable-Baselines3), tqc, recurrent_ppo (sb3-contrib) and ppo_lagrangian (PPO on
the reward less lambda x the safety cost info["cost"], lambda raised by dual ascent while the
episodes' safety cost per hour exceeds constraint.budget_s_per_h); each has its file and budget.

Ctrl-C saves a checkpoint (exit status 130); --resume DIR continues.

sweeps: train.py sweep --out DIR runs Ray Tune over hyperparameters and seeds (train.py sweep --help)."""

#: ``train.py sweep --help``: its description, then the epilog.
SWEEP_HELP = """Sweep hyperparameters and seeds with Ray Tune: Optuna search, ASHA stopping, the best trial exported.

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


def build_parser(prog: str = "train.py") -> argparse.ArgumentParser:
    p = OneLineErrorParser(prog=prog, description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter,
                           epilog=examples(EXAMPLES) + "\n\n" + NOTES)
    d = add_run_options(p)
    p.add_argument("--task", default=None, metavar="NAME",
                   help=f"train for a benchmark task ({', '.join(list_tasks())}; a name alone is its newest version): "
                        "its training cycles and scenario, instead of --cycles and --scenario")
    p.add_argument("--seed", type=int, default=None, help="seed of the model and environments, 0 or more (default: 0)")
    p.add_argument("--out", default=None, metavar="DIR", help="run directory, new or empty (required unless --resume)")
    p.add_argument("--checkpoint-freq", type=int, default=None, metavar="N",
                   help=f"checkpoint every N env-steps; {per_algo(d, 'checkpoint_freq')}")
    p.add_argument("--resume", default=None, metavar="DIR", help="continue the run in DIR from its last checkpoint")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--quiet", action="store_true", help="no evaluation lines")
    return p


def command_line(argv: Sequence[str]) -> str:
    """The command as it would be typed again (saved in the run's ``command.txt``)."""
    line = " ".join(shlex.quote(a) for a in argv)
    return f"python {line}" if argv and argv[0].endswith(".py") else line


def run(args: argparse.Namespace, command: str) -> tuple[dict[str, Any], str]:
    """Train or resume as ``args`` say; returns the run's result and its directory."""
    from hev_thermal_env.training import build_config, parse_overrides, resume, train

    progress, verbose = not args.no_progress, 0 if args.quiet else 1
    if args.resume is not None:
        refuse_settings_with_resume(args, "config.yaml")
        return resume(args.resume, progress=progress, verbose=verbose, command=command), args.resume
    if args.out is None:
        raise ValueError("--out DIR is required (or --resume DIR)")
    config = build_config(
        args.algo or "ppo", hyperparams_file=args.hyperparams, overrides=parse_overrides(args.hp or []),
        cycles=args.cycles, scenario=args.scenario, timesteps=args.timesteps, n_envs=args.n_envs,
        seed=0 if args.seed is None else args.seed, eval_cycles=eval_cycles(args), eval_scenarios=args.eval_scenarios,
        eval_freq=args.eval_freq, checkpoint_freq=args.checkpoint_freq, command=command, task=args.task)
    return train(config, args.out, progress=progress, verbose=verbose), args.out


def main(argv: list[str] | None = None) -> int:
    prog = program_name(argv, "train.py")
    given = list(sys.argv[1:] if argv is None else argv)
    command = command_line([prog, *given])
    if given[:1] == ["sweep"] or "--sweep" in given:
        rest = given[1:] if given[:1] == ["sweep"] else given
        return sweep_main([a for a in rest if a != "--sweep"], prog=f"{prog} sweep", command=command)

    def body() -> int:
        args = build_parser(prog).parse_args(argv)
        result, out = run(args, command)
        share = result.get("env_share")
        print(f"done: {result['timesteps_done']} timesteps in {result['wall_s']:.1f} s "
              f"({result.get('steps_per_s') or 0:.0f} steps/s this session"
              f"{f', env step {100 * share:.1f} % of it' if share is not None else ''}); model in {out}/model.zip")
        return 0

    return run_program(body, prog)


def sweep_parser(prog: str) -> argparse.ArgumentParser:
    p = OneLineErrorParser(prog=prog, description=SWEEP_HELP.split("\n\n")[0],
                           formatter_class=argparse.RawDescriptionHelpFormatter,
                           epilog="\n\n".join(SWEEP_HELP.split("\n\n")[1:]))
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


def sweep_main(argv: list[str], prog: str = "train.py sweep", command: str | None = None) -> int:
    """``train.py sweep``: Ray Tune over hyperparameters and seeds (:data:`SWEEP_HELP`)."""
    from hev_thermal_env.evaluation.executors import ExecutorError

    def body() -> int:
        report, out = sweep(sweep_parser(prog).parse_args(argv), command or prog)
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


if __name__ == "__main__":
    sys.exit(main())
