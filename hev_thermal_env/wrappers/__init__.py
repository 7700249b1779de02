"""Adapters of the envs to other libraries' interfaces: :class:`~.sb3.Sb3VecEnv`, the native vector env as a
Stable-Baselines3 ``VecEnv``."""

from .sb3 import Sb3VecEnv

__all__ = ["Sb3VecEnv"]
