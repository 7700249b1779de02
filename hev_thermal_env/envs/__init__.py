"""The MDP layer: the single env, the batch engine, the vector env, the reward, the spaces and rendering.

* :class:`HevThermalEnv` (``HevThermal-v0``), :mod:`.hev_env`: the thin single env.
* :class:`HevThermalVectorEnv`, :mod:`.vector_env`: n sub-envs stepped in one call.
* :mod:`.batch`: the batch engine both step through; :mod:`.episodes`: what a reset draws.
* :mod:`.reward`: the reward, written once (env, vector env, DP, ECMS); :mod:`.spaces`: the
  observation and info layout; :mod:`.codes`: the reset info's cycle and coolant codes.
"""

from .codes import coolant_mode, cycle_name
from .hev_env import HevThermalEnv
from .reward import REWARD_TERMS, RewardParams
from .spaces import EPISODE_INFO_KEYS, INFO_KEYS, RESET_INFO_KEYS, observation_names
from .vector_env import HevThermalVectorEnv

__all__ = ["EPISODE_INFO_KEYS", "INFO_KEYS", "REWARD_TERMS", "RESET_INFO_KEYS", "HevThermalEnv", "HevThermalVectorEnv",
           "RewardParams", "coolant_mode", "cycle_name", "observation_names"]
