"""The MDP layer: :class:`HevThermalEnv` (:mod:`.hev_env`) and :class:`HevThermalVectorEnv` (:mod:`.vector_env`),
both stepping through the batch engine (:mod:`.batch`); what a reset draws (:mod:`.episodes`); the reward
(:mod:`.reward`); the observation and info layout (:mod:`.spaces`); rendering (:mod:`.render`).
"""

from .hev_env import HevThermalEnv
from .spaces import EPISODE_INFO_KEYS, INFO_DTYPES, INFO_KEYS, observation_names
from .vector_env import HevThermalVectorEnv

__all__ = ["EPISODE_INFO_KEYS", "INFO_DTYPES", "INFO_KEYS", "HevThermalEnv", "HevThermalVectorEnv",
           "observation_names"]
