"""hev-thermal-env: a Gymnasium environment and energy-management benchmark for a parallel hybrid city bus whose
permanent-magnet traction motor heats up, derates and cuts out.

``import hev_thermal_env`` registers ``HevThermal-v2`` and ``HevThermal-v1`` (in a fresh worker process that has not
imported the package, ``gymnasium.make("hev_thermal_env:HevThermal-v2")`` imports it) and loads the vehicle and the
envs; the other rooms (docs/architecture.md) are imported on demand, ``.training`` (imports torch) among them.
"""

from gymnasium.envs.registration import register, registry

from .cycles import Cycle, cycle_from_arrays, generate_bus_cycle, list_cycles, load_cycle
from .envs import HevThermalEnv, HevThermalVectorEnv
from .physics import Conditions, ConfigError, PhysicsCore, VehicleConfig, paper_bus
from .simulate import SimResult, simulate

__version__ = "0.1.0"

for _version in (1, 2):  # one MDP class; the physics version sets the vehicle's and the reward's defaults
    if f"HevThermal-v{_version}" not in registry:
        register(id=f"HevThermal-v{_version}", entry_point="hev_thermal_env.envs.hev_env:HevThermalEnv",
                 vector_entry_point="hev_thermal_env.envs.vector_env:HevThermalVectorEnv",
                 kwargs={"physics": _version})

__all__ = [
    "Conditions", "ConfigError", "Cycle", "HevThermalEnv", "HevThermalVectorEnv", "PhysicsCore", "SimResult",
    "VehicleConfig", "cycle_from_arrays",
    "generate_bus_cycle", "list_cycles", "load_cycle", "paper_bus", "simulate",
]
