"""Adapters of the envs to other libraries' interfaces: :class:`~.sb3.Sb3VecEnv`, the native vector env as a
Stable-Baselines3 ``VecEnv`` (:mod:`.sb3` imports stable-baselines3 and torch; this package imports nothing)."""
