"""hev-thermal-env: a Gymnasium environment and energy-management benchmark for a parallel hybrid
city bus whose permanent-magnet traction motor heats up, derates and cuts out.

``import hev_thermal_env`` registers ``HevThermal-v0`` and gives the environments as
``hev_thermal_env.HevThermalEnv`` and ``hev_thermal_env.HevThermalVectorEnv``. In a fresh worker
process that has not imported the package (RLlib's remote runners, a ``multiprocessing`` spawn),
``gymnasium.make("hev_thermal_env:HevThermal-v0")`` imports it and makes the env in one call.
The rooms:

* ``hev_thermal_env.physics``, ``.cycles``, ``.envs`` (single env, vector env, spaces, reward): the
  vehicle and the environments, imported with the package;
* imported on demand: ``hev_thermal_env.wrappers`` (the SB3 ``VecEnv`` adapter);
  ``hev_thermal_env.planning``, the planners over a known cycle (SOC DP, the thermal optimum);
  ``hev_thermal_env.agents``, the strategies (rule, ECMS, DP, PPO) behind one protocol, with the
  shipped policy and the training hyperparameters (the source tree's top-level ``agents/`` folder,
  installed as ``hev_thermal_env.agents``); ``hev_thermal_env.evaluation`` (run a strategy, the
  benchmark, the paper report, plots); ``hev_thermal_env.training`` (SB3 training: config,
  artifacts, callbacks, loop, export; imports torch); ``hev_thermal_env.cli`` (the ``evaluate.py`` /
  ``train.py`` programs, ``hev-evaluate``, ``hev-train``).
"""

from gymnasium.envs.registration import register, registry

from .cycles import Cycle, cycle_from_arrays, generate_bus_cycle, list_cycles, load_cycle
from .envs import HevThermalEnv, HevThermalVectorEnv
from .physics import Conditions, ConfigError, PhysicsCore, VehicleConfig, paper_bus
from .simulate import SimResult, simulate

__version__ = "0.1.0"

if "HevThermal-v0" not in registry:
    register(id="HevThermal-v0", entry_point="hev_thermal_env.envs.hev_env:HevThermalEnv",
             vector_entry_point="hev_thermal_env.envs.vector_env:HevThermalVectorEnv")

__all__ = [
    "Conditions", "ConfigError", "Cycle", "HevThermalEnv", "HevThermalVectorEnv", "PhysicsCore", "SimResult",
    "VehicleConfig", "cycle_from_arrays",
    "generate_bus_cycle", "list_cycles", "load_cycle", "paper_bus", "simulate",
]
