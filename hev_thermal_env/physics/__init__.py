"""Physics of the parallel hybrid bus: one module per component, one batched step (``core``).

Imports neither gymnasium nor torch.
"""

from .battery import BatteryParams
from .config import Conditions, PowertrainParams, VehicleConfig, paper_bus
from .core import N_OUT, N_STATE, OUT_NAMES, STATE_NAMES, PhysicsCore
from .driveline import DrivelineParams
from .engine import EngineParams
from .glider import GliderParams
from .motor import MotorParams
from .params import ConfigError, Params
from .thermal import ThermalParams

__all__ = [
    "BatteryParams", "Conditions", "ConfigError", "DrivelineParams", "EngineParams", "GliderParams",
    "MotorParams", "N_OUT", "N_STATE", "OUT_NAMES", "Params", "PhysicsCore", "PowertrainParams",
    "STATE_NAMES", "ThermalParams", "VehicleConfig", "paper_bus",
]
