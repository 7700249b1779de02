#!/usr/bin/env python
"""Train an SB3 agent (PPO or SAC) as the energy-management strategy of the hybrid bus.

Examples::

    python train.py --algo ppo --cycles hwfet random_bus --scenario random --timesteps 5000000 \\
        --n-envs 32 --seed 0 --out runs/ppo_s0
    python train.py --algo ppo --hp gamma=0.99 'policy_kwargs={net_arch: [128, 128]}' --out runs/ppo_wide
    python train.py --resume runs/ppo_s0          # continue an interrupted run to its total

Hyperparameters come from ``agents/hyperparams/<algo>.yaml`` (or ``--hyperparams FILE``);
``--hp key=value`` overrides any of them: values are YAML (``0.99``, ``[64, 64]``,
``{net_arch: [64, 64], activation_fn: tanh}``, ``lin_3e-4`` for a linear decay), ``dict(k=v, ...)``
is accepted too, and dotted keys reach inside mappings (``policy_kwargs.net_arch=[64,64]``,
``env.reward.soc_deviation_weight=1.0``). The run directory gets ``model.zip``, ``best_model.zip``,
``vecnormalize.pkl``, ``config.yaml``, ``command.txt``, ``checkpoints/``, ``tb/`` (TensorBoard),
``evaluations.csv`` and ``training_curve.png`` (see :mod:`agents.training`).

Ctrl-C saves a checkpoint and exits with status 130; ``--resume DIR`` continues. Errors in the
input are reported in one line with a non-zero exit status. Torch runs on one thread
(environment variable ``HEV_TORCH_THREADS`` to change).
"""

from __future__ import annotations

import argparse
import os
import sys

SETTING_FLAGS = ("algo", "cycles", "scenario", "timesteps", "n_envs", "seed", "out", "hp", "hyperparams", "vec",
                 "eval_cycles", "eval_scenarios", "eval_freq", "checkpoint_freq")


class OneLineErrorParser(argparse.ArgumentParser):
    """Usage errors in one line (``train.py: error: ...``), exit status 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    p = OneLineErrorParser(prog="train.py", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="\n\n".join(__doc__.split("\n\n")[1:]))
    p.add_argument("--algo", default=None, help="ppo (default) or sac")
    p.add_argument("--cycles", nargs="+", default=None,
                   help="training cycles: built-in names, CSV paths or random_bus (default from the file)")
    p.add_argument("--scenario", default=None, help="paper, hot or random (default from the hyperparameter file)")
    p.add_argument("--timesteps", type=int, default=None, help="total env-steps (default from the hyperparameter file)")
    p.add_argument("--n-envs", type=int, default=None, help="parallel environments (default from the file)")
    p.add_argument("--seed", type=int, default=None, help="seed of the model and the environments (default 0)")
    p.add_argument("--out", default=None, help="run directory (new or empty)")
    p.add_argument("--hp", nargs="+", default=None, metavar="KEY=VALUE", help="hyperparameter overrides")
    p.add_argument("--hyperparams", default=None, metavar="FILE", help="hyperparameter YAML file")
    p.add_argument("--vec", default=None, help="native (batched env, default), subproc or dummy")
    p.add_argument("--eval-cycles", nargs="*", default=None,
                   help="evaluation cycles, not trained on (default beijing us06; none disables evaluation)")
    p.add_argument("--eval-scenarios", nargs="+", default=None, help="evaluation scenarios (default paper)")
    p.add_argument("--eval-freq", type=int, default=None, help="evaluate every N env-steps")
    p.add_argument("--checkpoint-freq", type=int, default=None, help="checkpoint every N env-steps")
    p.add_argument("--resume", default=None, metavar="DIR", help="continue the run in DIR from its last checkpoint")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--quiet", action="store_true", help="no evaluation lines")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from agents.training import TrainingInterrupted, build_config, command_line, parse_overrides, resume, train

    command = command_line([os.path.basename(sys.argv[0]) if argv is None else "train.py",
                            *(sys.argv[1:] if argv is None else argv)])
    progress, verbose = not args.no_progress, 0 if args.quiet else 1
    try:
        if args.resume is not None:
            given = [f"--{f.replace('_', '-')}" for f in SETTING_FLAGS if getattr(args, f) is not None]
            if given:
                raise ValueError(f"--resume takes every setting from {args.resume}/config.yaml; "
                                 f"drop {' '.join(given)}")
            result = resume(args.resume, progress=progress, verbose=verbose, command=command)
            out = args.resume
        else:
            if args.out is None:
                raise ValueError("--out DIR is required (or --resume DIR)")
            config = build_config(
                args.algo or "ppo", hyperparams_file=args.hyperparams, overrides=parse_overrides(args.hp or []),
                cycles=args.cycles, scenario=args.scenario, timesteps=args.timesteps, n_envs=args.n_envs,
                seed=0 if args.seed is None else args.seed, vec=args.vec or "native", eval_cycles=args.eval_cycles,
                eval_scenarios=args.eval_scenarios, eval_freq=args.eval_freq, checkpoint_freq=args.checkpoint_freq,
                command=command)
            result = train(config, args.out, progress=progress, verbose=verbose)
            out = args.out
    except TrainingInterrupted as exc:
        print(f"train.py: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("train.py: interrupted", file=sys.stderr)
        return 130
    except (ValueError, FileNotFoundError, NotADirectoryError, IsADirectoryError, PermissionError) as exc:
        print(f"train.py: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    share = result.get("env_share")
    print(f"done: {result['timesteps_done']} timesteps in {result['wall_s']:.1f} s "
          f"({result.get('steps_per_s') or 0:.0f} steps/s this session"
          f"{f', env step {100 * share:.1f} % of it' if share is not None else ''}); model in {out}/model.zip")
    return 0


if __name__ == "__main__":
    sys.exit(main())
