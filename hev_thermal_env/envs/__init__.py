"""The MDP layer: :class:`HevThermalEnv` (``HevThermal-v1``, :mod:`.hev_env`) and :class:`HevThermalVectorEnv`
(:mod:`.vector_env`), both stepping through the batch engine (:mod:`.batch`); what a reset draws (:mod:`.episodes`); the
reward, written once (:mod:`.reward`); the observation and info layout and codes (:mod:`.spaces`, :mod:`.observation`);
rendering (:mod:`.render`).
"""

from .hev_env import HevThermalEnv
from .reward import REWARD_TERMS, RewardParams
from .spaces import EPISODE_INFO_KEYS, INFO_KEYS, RESET_INFO_KEYS, coolant_mode, cycle_name, observation_names
from .vector_env import HevThermalVectorEnv

__all__ = ["EPISODE_INFO_KEYS", "INFO_KEYS", "REWARD_TERMS", "RESET_INFO_KEYS", "HevThermalEnv", "HevThermalVectorEnv",
           "RewardParams", "coolant_mode", "cycle_name", "observation_names"]
