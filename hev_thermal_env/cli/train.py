"""Train an SB3 agent (PPO or SAC) as the energy-management strategy of the hybrid bus.

The program behind ``train.py`` and the ``hev-train`` command; ``--help`` shows the examples
(:data:`EXAMPLES`) and every default, the run settings taken from the algorithm's hyperparameter
file (``agents/hyperparams/<algo>.yaml``, :data:`~hev_thermal_env.agents.HYPERPARAMS_DIR`).
``--hp key=value`` overrides any hyperparameter (values are YAML; dotted keys reach inside
mappings). The run directory gets ``model.zip``, ``best_model.zip``, ``vecnormalize.pkl``,
``config.yaml``, ``command.txt``, ``checkpoints/``, ``tb/`` (TensorBoard), ``evaluations.csv``,
``validation.csv`` and ``training_curve.png`` (see :mod:`hev_thermal_env.training`).

Ctrl-C saves a checkpoint and exits with status 130; ``--resume DIR`` continues. Errors in the
input (an unknown hyperparameter, a value of the wrong type, an output directory that cannot be
written) are reported in one line with a non-zero exit status before anything is created. Torch
runs on one thread (environment variable ``HEV_TORCH_THREADS`` to change).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Sequence
from typing import Any

from hev_thermal_env.agents import HYPERPARAMS_DIR
from hev_thermal_env.agents.policy_files import ALGORITHMS
from hev_thermal_env.cycles import list_cycles, list_families
from hev_thermal_env.io import read_yaml_mapping
from hev_thermal_env.scenarios import list_scenarios
from hev_thermal_env.training import TrainingInterrupted, build_config, parse_overrides, resume, train
from hev_thermal_env.training.config import DEFAULT_EVAL_CYCLES, VEC_MODES

from .errors import EXIT_INTERRUPTED, USER_ERRORS, one_line_warnings, program_name, report
from .parsing import HelpFormatter, OneLineErrorParser, examples

ALGOS = tuple(ALGORITHMS)

SETTING_FLAGS = ("algo", "cycles", "scenario", "timesteps", "n_envs", "seed", "out", "hp", "hyperparams", "vec",
                 "eval_cycles", "eval_scenarios", "eval_freq", "checkpoint_freq")


EXAMPLES = (
    "python train.py --algo ppo --cycles bus_long bus_congested bus_mixed --scenario random_service \\",
    "    --timesteps 5000000 --eval-cycles validation_bus:0..4 --eval-scenarios paper full_bus \\",
    "    --n-envs 32 --seed 0 --out runs/ppo_s0",
    "python train.py --algo ppo --hp gamma=0.99 'policy_kwargs={net_arch: [128, 128]}' --out runs/ppo_wide",
    "python train.py --algo sac --hp learning_rate=lin_3e-4 env.reward.soc_deviation_weight=10 --out runs/sac",
    "python train.py --resume runs/ppo_s0                 # continue an interrupted run to its total",
    "python evaluate.py run --cycle beijing --strategy ppo:runs/ppo_s0   # drive a trained run",
)

NOTES = """\
hyperparameters: agents/hyperparams/<algo>.yaml (or --hyperparams FILE); --hp key=value overrides
any of them. Values are YAML: 0.99, [64, 64], {net_arch: [64, 64], activation_fn: tanh}, lin_3e-4
(a linear decay); dict(k=v, ...) is accepted too; dotted keys reach inside mappings
(policy_kwargs.net_arch=[64,64], env.reward.soc_deviation_weight=1.0).

selection: best_model.zip is the checkpoint with the best eval.selection score on the evaluation
cycles (default fuel_vs_ecms: lowest mean corrected fuel / ECMS, |dSOC| > 0.02 disqualifies); at the
end the best and final models are scored on eval.final_cycles (validation.csv).

outputs in --out: model.zip, best_model.zip, vecnormalize.pkl, config.yaml, command.txt,
checkpoints/, tb/ (TensorBoard), evaluations.csv, validation.csv, training_curve.png.

Ctrl-C saves a checkpoint (exit status 130); --resume DIR continues.

sweeps: train.py sweep --out DIR runs Ray Tune over hyperparameters and seeds (train.py sweep --help)."""


def file_defaults() -> dict[str, dict[str, Any]]:
    """The run settings of each algorithm's hyperparameter file (what the options default to)."""
    out = {}
    for algo in ALGOS:
        hp = read_yaml_mapping(HYPERPARAMS_DIR / f"{algo}.yaml")
        env, ev = hp.get("env") or {}, hp.get("eval") or {}
        out[algo] = {"cycles": " ".join(map(str, env.get("cycles", []))), "scenario": env.get("scenario"),
                     "timesteps": hp.get("n_timesteps"), "n_envs": hp.get("n_envs"),
                     "eval_cycles": " ".join(map(str, ev.get("cycles", DEFAULT_EVAL_CYCLES))),
                     "eval_scenarios": " ".join(map(str, ev.get("scenarios", ["paper"]))),
                     "eval_freq": ev.get("freq"), "checkpoint_freq": hp.get("checkpoint_freq")}
    return out


def _per_algo(defaults: dict[str, dict[str, Any]], key: str) -> str:
    values = [f"{defaults[a][key]} ({a})" for a in ALGOS]
    return "default from the hyperparameter file: " + ", ".join(values)


def build_parser(prog: str = "train.py") -> argparse.ArgumentParser:
    d = file_defaults()
    p = OneLineErrorParser(prog=prog, description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter,
                           epilog=examples(EXAMPLES) + "\n\n" + NOTES)
    p.add_argument("--algo", default=None, help=f"algorithm: {' or '.join(ALGOS)} (default: ppo)")
    p.add_argument("--cycles", nargs="+", default=None, metavar="CYCLE",
                   help=f"training cycles: cycle families ({', '.join(list_families())}: a fresh generated cycle "
                        f"per episode), built-in names ({', '.join(list_cycles())}), FAMILY:SEED or CSV paths; "
                        f"{_per_algo(d, 'cycles')}")
    p.add_argument("--scenario", default=None, metavar="S",
                   help=f"one of {', '.join(list_scenarios())}; {_per_algo(d, 'scenario')}")
    p.add_argument("--timesteps", type=int, default=None, metavar="N",
                   help=f"total env-steps; {_per_algo(d, 'timesteps')}")
    p.add_argument("--n-envs", type=int, default=None, metavar="N",
                   help=f"parallel environments; {_per_algo(d, 'n_envs')}")
    p.add_argument("--seed", type=int, default=None, help="seed of the model and the environments, 0 or more "
                                                          "(default: 0)")
    p.add_argument("--out", default=None, metavar="DIR", help="run directory, new or empty (required unless --resume)")
    p.add_argument("--hp", nargs="+", default=None, metavar="KEY=VALUE", help="hyperparameter overrides (see below)")
    p.add_argument("--hyperparams", default=None, metavar="FILE",
                   help="hyperparameter YAML file (default: agents/hyperparams/<algo>.yaml)")
    p.add_argument("--vec", default=None, metavar="MODE",
                   help=f"vector env, one of {', '.join(VEC_MODES)}: native is one batched env (the default), "
                        "subproc and dummy SB3's vector envs")
    p.add_argument("--eval-cycles", nargs="*", default=None, metavar="CYCLE",
                   help=f"evaluation cycles the checkpoints are scored on, not trained on (validation_bus:A..B: "
                        f"validation cycles A to B); none disables evaluation; {_per_algo(d, 'eval_cycles')}")
    p.add_argument("--eval-scenarios", nargs="+", default=None, metavar="S",
                   help=f"evaluation scenarios; {_per_algo(d, 'eval_scenarios')}")
    p.add_argument("--eval-freq", type=int, default=None, metavar="N",
                   help=f"evaluate every N env-steps; {_per_algo(d, 'eval_freq')}")
    p.add_argument("--checkpoint-freq", type=int, default=None, metavar="N",
                   help=f"checkpoint every N env-steps; {_per_algo(d, 'checkpoint_freq')}")
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
    progress, verbose = not args.no_progress, 0 if args.quiet else 1
    if args.resume is not None:
        given = [f"--{f.replace('_', '-')}" for f in SETTING_FLAGS if getattr(args, f) is not None]
        if given:
            raise ValueError(f"--resume takes every setting from {args.resume}/config.yaml; drop {' '.join(given)}")
        return resume(args.resume, progress=progress, verbose=verbose, command=command), args.resume
    if args.out is None:
        raise ValueError("--out DIR is required (or --resume DIR)")
    config = build_config(
        args.algo or "ppo", hyperparams_file=args.hyperparams, overrides=parse_overrides(args.hp or []),
        cycles=args.cycles, scenario=args.scenario, timesteps=args.timesteps, n_envs=args.n_envs,
        seed=0 if args.seed is None else args.seed, vec=args.vec or "native", eval_cycles=args.eval_cycles,
        eval_scenarios=args.eval_scenarios, eval_freq=args.eval_freq, checkpoint_freq=args.checkpoint_freq,
        command=command)
    return train(config, args.out, progress=progress, verbose=verbose), args.out


def main(argv: list[str] | None = None) -> int:
    prog = program_name(argv, "train.py")
    given = list(sys.argv[1:] if argv is None else argv)
    command = command_line([prog, *given])
    if given[:1] == ["sweep"] or "--sweep" in given:
        from .sweep import main as sweep_main

        rest = given[1:] if given[:1] == ["sweep"] else given
        return sweep_main([a for a in rest if a != "--sweep"], prog=f"{prog} sweep", command=command)
    args = build_parser(prog).parse_args(argv)
    try:
        with one_line_warnings(prog):
            result, out = run(args, command)
    except TrainingInterrupted as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except USER_ERRORS as exc:
        return report(exc, prog)
    share = result.get("env_share")
    print(f"done: {result['timesteps_done']} timesteps in {result['wall_s']:.1f} s "
          f"({result.get('steps_per_s') or 0:.0f} steps/s this session"
          f"{f', env step {100 * share:.1f} % of it' if share is not None else ''}); model in {out}/model.zip")
    return 0


if __name__ == "__main__":
    sys.exit(main())
