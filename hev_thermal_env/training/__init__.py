"""Training of SB3 agents (PPO, SAC) on ``HevThermal-v0``: the library behind ``train.py``.

A run is described by one plain dict, its config (:mod:`.config`: :func:`build_config` from the
algorithm's hyperparameter file, ``--hp`` overrides and the command line), which :func:`train` runs
(or :func:`resume` continues) into a run directory (:mod:`.artifacts`); :func:`load_policy` loads a
trained policy and :func:`export_policy` packs one for shipping. Sweeps (:mod:`.sweep`, the ``ray``
extra) are not imported here. Importing this package imports torch and Stable-Baselines3
(``import hev_thermal_env`` does not). See docs/training.md.
"""

from hev_thermal_env.agents.policy_files import load_policy

from .callbacks import TrainingInterrupted
from .config import build_config
from .export import export_policy
from .loop import resume, train
from .overrides import parse_overrides

__all__ = ["TrainingInterrupted", "build_config", "export_policy", "load_policy", "parse_overrides", "resume", "train"]
