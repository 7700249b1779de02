"""Train an SB3 agent (PPO, SAC, TQC, RecurrentPPO or PPO-Lagrangian) as the energy-management strategy of the bus.

The program behind ``train.py`` and ``hev-train``, a thin layer over :mod:`hev_thermal_env.training`;
``--help`` shows the examples, the notes and every default (from the hyperparameter files).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Sequence
from typing import Any

from hev_thermal_env.tasks import list_tasks

from .errors import (
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

tuning: rl-zoo3's Optuna optimiser tunes the RL track's files (sac, tqc, recurrent_ppo, ppo_rl):
python -m rl_zoo3.train with -optimize (docs/scaling-out.md)."""


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

    def body() -> int:
        args = build_parser(prog).parse_args(argv)
        result, out = run(args, command)
        share = result.get("env_share")
        print(f"done: {result['timesteps_done']} timesteps in {result['wall_s']:.1f} s "
              f"({result.get('steps_per_s') or 0:.0f} steps/s this session"
              f"{f', env step {100 * share:.1f} % of it' if share is not None else ''}); model in {out}/model.zip")
        return 0

    return run_program(body, prog)


if __name__ == "__main__":
    sys.exit(main())
