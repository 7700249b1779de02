"""Physics of the parallel hybrid bus: one module per component, one batched step (``core``); imports neither
gymnasium nor torch."""

from .battery import BatteryParams
from .config import Conditions, PowertrainParams, VehicleConfig, paper_bus
from .core import PhysicsCore
from .driveline import DrivelineParams
from .engine import EngineParams
from .glider import GliderParams
from .motor import MotorParams
from .params import ConfigError
from .thermal import ThermalParams

__all__ = [
    "BatteryParams", "Conditions", "ConfigError", "DrivelineParams", "EngineParams", "GliderParams", "MotorParams",
    "PhysicsCore", "PowertrainParams", "ThermalParams", "VehicleConfig", "paper_bus",
]
