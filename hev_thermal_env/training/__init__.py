"""Training of SB3 agents (PPO, SAC) on ``HevThermal-v0``: the library behind ``train.py``.

A run is described by one plain dict, its *config* (saved as ``DIR/config.yaml``), built by
:func:`build_config` from the algorithm's hyperparameter file (``agents/hyperparams/<algo>.yaml``,
installed as ``hev_thermal_env/agents/hyperparams/``), overrides (``--hp key=value``) and the
command-line settings. :func:`train` runs it, or continues it (:func:`resume`), and writes an
rl-baselines3-zoo-like run directory (:mod:`.artifacts`); :func:`load_policy` loads a trained
policy from it and :func:`export_policy` packs one for shipping.

Modules, each named for what it holds:

* :mod:`.hyperparams`: the algorithms, their hyperparameter files, constructor arguments and checks;
* :mod:`.overrides`: ``--hp`` parsing; :mod:`.schedules`: ``lin_<x>`` schedules;
* :mod:`.config`: build, validate, save and load a run's config;
* :mod:`.artifacts`: the run directory's files, models and statistics, :class:`LoadedPolicy`;
* :mod:`.envs`: the training vector env (the native batched env) and ``VecNormalize``;
* :mod:`.evaluator`: deterministic evaluation on cycles not trained on;
* :mod:`.selection`: the rule that picks ``best_model.zip`` (corrected fuel relative to ECMS by default,
  SOC drift disqualifies); :mod:`.validation_report`: the best and final models on the full validation set;
* :mod:`.callbacks`: checkpoints, evaluation and signals during ``learn``;
* :mod:`.loop`: :func:`train` and :func:`resume`;
* :mod:`.curves`: ``training_curve.png``; :mod:`.export`: :func:`export_policy`;
* :mod:`.sweep`: Ray Tune sweeps over hyperparameters and seeds (the ``ray`` extra; not imported
  here), with :mod:`.sweep_space` (search spaces), :mod:`.sweep_trial` (the trainable),
  :mod:`.sweep_report` (tables, IQM and bootstrap intervals, export) and :mod:`.sweep_plot`.

Importing this package imports torch and Stable-Baselines3 (``import hev_thermal_env`` does not).
"""

from hev_thermal_env.agents.policy_files import LoadedPolicy, load_policy

from .callbacks import TrainingInterrupted
from .config import build_config, load_run_config
from .export import export_policy
from .loop import resume, train
from .overrides import parse_overrides

__all__ = ["LoadedPolicy", "TrainingInterrupted", "build_config", "export_policy", "load_policy", "load_run_config",
           "parse_overrides", "resume", "train"]
