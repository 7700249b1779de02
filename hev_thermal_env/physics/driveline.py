"""Driveline: wheel ← final drive ← automated manual gearbox ← torque coupler ← clutch ← engine.

The motor joins the engine shaft through the torque coupler ahead of the gearbox (the paper's "torque synthesizer"),
both on the gearbox input shaft ("coupler shaft"); the motor turns at ``coupler_ratio`` times its speed (ADVISOR's
TC_DUMMY rule, 0.99 · max motor speed / max engine speed; lossless). The gear is a stateless shift map on vehicle speed
and load: the highest gear whose shaft speed reaches the up-shift speed, rising with the load fraction from
``upshift_low_load_rpm`` to ``upshift_full_load_rpm`` (ADVISOR's PTC_PAR schedule without its hysteresis, so that
dynamic programming needs no gear state).
"""

from __future__ import annotations

import dataclasses

from .jit import jit
from .params import RPM, Layout, Params, Slot, spec

MAX_GEARS = 8


@dataclasses.dataclass(frozen=True)
class DrivelineParams(Params):
    """Gearbox, final drive and torque coupler."""

    gear_ratios: tuple = spec((5.0, 3.3, 2.37, 1.45, 1.0), "AMT gear ratios, first to top (input/output speed)",
                              min=0.1, max=20.0)
    final_drive_ratio: float = spec(5.6, "final drive ratio (calibrated to Table 3)", min=0.5, max=20.0)
    gearbox_efficiency: float = spec(0.96, "AMT efficiency, constant", min=0.5, max=1.0)
    final_drive_efficiency: float = spec(0.97, "final drive efficiency, constant", min=0.5, max=1.0)
    coupler_ratio: float = spec(0.99 * 6000.0 / 3500.0, "motor speed / coupler shaft speed (ADVISOR TC_DUMMY rule)",
                                min=0.1, max=10.0)
    upshift_low_load_rpm: float = spec(1100.0, "shaft speed above which to up-shift at zero load", min=300.0)
    upshift_full_load_rpm: float = spec(2400.0, "shaft speed above which to up-shift at full load", min=300.0)

    def validate(self) -> None:
        g = self.gear_ratios
        self.require(1 <= len(g) <= MAX_GEARS, "gear_ratios", f"need 1 to {MAX_GEARS} gears, got {len(g)}")
        self.require(all(a > b for a, b in zip(g, g[1:])), "gear_ratios", f"must decrease from first to top, got {g}")
        self.require(self.upshift_full_load_rpm >= self.upshift_low_load_rpm, "upshift_full_load_rpm",
                     "must be >= upshift_low_load_rpm")


LAYOUT = DrivelineParams.LAYOUT = Layout.of_fields(DrivelineParams, replace={
    "gear_ratios": (Slot("n_gears", fill=lambda p: len(p.gear_ratios), fields=()), Slot("gear_ratios", MAX_GEARS)),
    "upshift_low_load_rpm": Slot("upshift_low_load_radps", fill=lambda p: p.upshift_low_load_rpm * RPM,
                                 fields=("upshift_low_load_rpm",)),
    "upshift_full_load_rpm": Slot("upshift_full_load_radps", fill=lambda p: p.upshift_full_load_rpm * RPM,
                                  fields=("upshift_full_load_rpm",)),
})  # speeds in rad/s, the gear table padded
IDX = LAYOUT.index()


@jit
def overall_ratio(dl, gear):
    """Shaft speed / wheel speed in ``gear`` (0-based)."""
    return dl[IDX.gear_ratios + gear] * dl[IDX.final_drive_ratio]


@jit
def select_gear(dl, wheel_speed_radps, load_frac, shaft_max_radps):
    """Stateless shift map: highest gear whose shaft speed reaches the load-dependent up-shift speed."""
    n = int(dl[IDX.n_gears])
    lf = min(max(load_frac, 0.0), 1.0)
    up = dl[IDX.upshift_low_load_radps] + (dl[IDX.upshift_full_load_radps] - dl[IDX.upshift_low_load_radps]) * lf
    gear = 0
    lowest_ok = n - 1  # the lowest gear that does not over-speed; the top gear if none
    for k in range(n):
        w = wheel_speed_radps * overall_ratio(dl, k)
        if w <= shaft_max_radps:
            lowest_ok = min(lowest_ok, k)
            if w >= up:
                gear = k
    # if even first gear over-speeds, the lowest that does not (found in the same pass: speed rule in jit.py)
    if wheel_speed_radps * overall_ratio(dl, gear) > shaft_max_radps:
        gear = lowest_ok
    return gear


@jit
def shaft_torque_nm(dl, wheel_torque_nm, gear):
    """Coupler-shaft torque for a wheel torque: losses add when driving and subtract when braking."""
    eff = dl[IDX.gearbox_efficiency] * dl[IDX.final_drive_efficiency]
    r = overall_ratio(dl, gear)
    if wheel_torque_nm >= 0.0:
        return wheel_torque_nm / (r * eff)
    return wheel_torque_nm * eff / r


@jit
def wheel_torque_nm(dl, shaft_torque, gear):
    """Wheel torque for a coupler-shaft torque (inverse of :func:`shaft_torque_nm`)."""
    eff = dl[IDX.gearbox_efficiency] * dl[IDX.final_drive_efficiency]
    r = overall_ratio(dl, gear)
    if shaft_torque >= 0.0:
        return shaft_torque * r * eff
    return shaft_torque * r / eff
