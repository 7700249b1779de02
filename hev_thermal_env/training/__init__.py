"""Training of SB3 agents (PPO, SAC; TQC and RecurrentPPO from sb3-contrib; PPO-Lagrangian, :mod:`.lagrangian`) on
``HevThermal-v2``: the library behind ``train.py`` (docs/training.md).

A run is one plain dict, its config (:func:`build_config`), which :func:`train` runs (or :func:`resume`
continues) into a run directory; :func:`load_policy` loads its policy, :func:`export_policy` packs one for
shipping. Importing this package imports torch and Stable-Baselines3 (``import hev_thermal_env`` does not).
"""

from hev_thermal_env.agents.policy_files import load_policy

from .artifacts import export_policy
from .config import build_config
from .hyperparams import parse_overrides
from .loop import TrainingInterrupted, resume, train

__all__ = ["TrainingInterrupted", "build_config", "export_policy", "load_policy", "parse_overrides", "resume", "train"]
