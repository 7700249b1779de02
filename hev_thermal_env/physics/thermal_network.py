"""The motor's lumped thermal network, and the one thermal step both thermal models go through.

Nodes of ``ThermalParams.model = "network"`` (diagram, equations and every parameter's source: docs/thermal_model.md):
the winding (copper loss), the stator/housing, **the paper's lumped motor temperature** (iron and friction losses; air
convection, eqs 1 and 4, and radiation, eq 6), and the pumped coolant loop (jacket, the inverter's cold plate, a
thermostat valve and the radiator). Conductances at the start of the step, then one backward-Euler step of the three
temperatures (a tridiagonal solve): stable at any step, and the flows close the balance exactly,
C_w·ΔT_w + C_h·ΔT_h + C_c·ΔT_c = (Q_gen − Q_air − Q_rad − Q_radiator)·dt. ``"paper_eqs"`` (``thermal.py``): one
explicit-Euler node heated by every loss, the coolant held.
"""

from __future__ import annotations

import math

from . import thermal as thm
from .jit import jit
from .thermal import IDX


@jit
def split_loss_w(mapped_loss_w, elec_power_w, core_loss_w, inverter_efficiency, network):
    """Where the mapped loss (motor and inverter, ``motor.total_loss_w``) goes: (winding, housing, inverter, motor), W.

    The network: the inverter's share (1 − η_inv)·|P_elec| (at most the whole loss) heats its cold plate in the coolant;
    the motor keeps the rest, split between the housing (iron and friction, ``core_loss_w`` with the extra loss) and
    the winding (copper, and the derate's extra current) in proportion to their mapped parts. The paper's node heats
    with the sum."""
    q_inverter = min((1.0 - inverter_efficiency) * abs(elec_power_w), mapped_loss_w) if network else 0.0
    heat_w = mapped_loss_w - q_inverter
    keep = heat_w / mapped_loss_w if mapped_loss_w > 0.0 else 1.0
    q_housing = keep * core_loss_w
    return heat_w - q_housing, q_housing, q_inverter, heat_w


@jit
def radiator_core(ua_ref, ram_term, still_term, inv_ref_mps, expo, fan_mps, fan_on_c, inv_fan_band, coolant_temp_c,
                  fan_factor):
    """UA_ref·(v_face/v_ref)^n with v_face = max(ram air, fan, still air), from scalars: the largest of the three
    factors (the power is monotone); ram air's (ram_air_frac·v/v_ref)^n and still air's come precomputed."""
    fan = min(max((coolant_temp_c - fan_on_c) * inv_fan_band, 0.0), 1.0) * fan_factor
    factor = max(ram_term, still_term)
    if fan > 0.0:
        factor = max(factor, (fan * fan_mps * inv_ref_mps) ** expo)
    return ua_ref * factor


@jit
def flow_conductance(mcp, ua):
    """ε-NTU conductance of an exchanger fed by a flow of capacity rate ``mcp`` (W/K): mcp·(1 − exp(−UA/mcp))."""
    return mcp * (1.0 - math.exp(-ua / mcp)) if mcp > 0.0 else 0.0


@jit
def network_core(a_w, a_h, a_c, g_w, g, g_air, g_rad, ua, winding_c, housing_c, coolant_c, q_winding_w, q_housing_w,
                 q_coolant_w, ambient_c):
    """One backward-Euler step of the three nodes from scalars; ``a_*`` = heat capacity / step, ``g`` the jacket's and
    ``ua`` the radiator's conductance. Returns (winding, housing, coolant temperature, Q_air, Q_rad, Q_cool (housing to
    coolant), Q_radiator)."""
    # tridiagonal system in (T_w', T_h', T_c'): eliminate the winding and the coolant into the housing row
    inv_w = 1.0 / (a_w + g_w)
    inv_c = 1.0 / (a_c + g + ua)
    r_w = a_w * winding_c + q_winding_w
    r_c = a_c * coolant_c + ua * ambient_c + q_coolant_w
    g_a = g_air + g_rad
    t_h = ((a_h * housing_c + q_housing_w + g_a * ambient_c + g_w * r_w * inv_w + g * r_c * inv_c)
           / (a_h + g_w + g_a + g - g_w * g_w * inv_w - g * g * inv_c))
    t_w = (r_w + g_w * t_h) * inv_w
    t_c = (r_c + g * t_h) * inv_c
    return t_w, t_h, t_c, g_air * (t_h - ambient_c), g_rad * (t_h - ambient_c), g * (t_h - t_c), ua * (t_c - ambient_c)


@jit
def _radiation_conductance(eps_sigma_area, temp_c, ambient_c):
    """ε·σ·A·(T⁴ − T_a⁴)/(T − T_a) = ε·σ·A·(T² + T_a²)(T + T_a), kelvin: radiation linearised at T."""
    tk = temp_c + thm.KELVIN
    ta = ambient_c + thm.KELVIN
    return eps_sigma_area * (tk * tk + ta * ta) * (tk + ta)


@jit
def thermal_step(th, temp_c, winding_c, coolant_c, q_winding_w, q_housing_w, q_inverter_w, ambient_c, water_c,
                 coolant_factor, fan_factor, forced_term, ram_term, inv_dt):
    """One step of the selected thermal model from the motor (stator/housing) temperature ``temp_c``; ``inv_dt`` =
    1 / step; ``forced_term`` and ``ram_term``: the speed's factors of eq 4 and of the radiator.

    Returns (motor, winding, coolant temperature, Q_air, Q_rad, Q_cool (motor to coolant), Q_radiator (coolant to air),
    valve open). ``paper_eqs``: a perfect radiator at the run's water temperature (Q_radiator = Q_cool), the coolant
    node held. Every parameter is read before any branch (speed rule in jit.py).
    """
    network = th[IDX.model] == thm.MODEL_NETWORK
    c_m = th[IDX.motor_heat_capacity_j_per_k]
    c_w = th[IDX.winding_heat_capacity_j_per_k]
    c_h = th[IDX.housing_heat_capacity_j_per_k]
    c_c = th[IDX.coolant_heat_capacity_j_per_k]
    g_w = th[IDX.winding_conductance_w_per_k]
    mcp = th[IDX.coolant_mcp_w_per_k] * coolant_factor
    ua_jacket = th[IDX.jacket_ua_w_per_k]
    eps_sigma_area = th[IDX.eps_sigma_area]
    h_water_area = th[IDX.h_water_area_w_per_k]
    thermostat_c = th[IDX.thermostat_temp_c]
    valve = min(max((coolant_c - thermostat_c) * th[IDX.inv_valve_band_per_k], 0.0), 1.0)
    g_air = thm.air_conductance_core(th[IDX.h_air_base], th[IDX.h_air_natural], th[IDX.h_air_forced], forced_term,
                                     th[IDX.area_m2], temp_c, ambient_c)
    ua_ref, still = th[IDX.radiator_ua_w_per_k], th[IDX.still_air_term]
    inv_ref, expo = th[IDX.inv_radiator_ref_air_speed], th[IDX.radiator_air_exponent]
    fan_mps, fan_on, inv_fan_band = th[IDX.fan_air_speed_mps], th[IDX.fan_on_temp_c], th[IDX.inv_fan_band_per_k]
    if network:
        ua = radiator_core(ua_ref, ram_term, still, inv_ref, expo, fan_mps, fan_on, inv_fan_band, coolant_c, fan_factor)
        g_rad = _radiation_conductance(eps_sigma_area, temp_c, ambient_c)
        t_w, t_h, t_c, q_air, q_rad, q_cool, q_radiator = network_core(
            c_w * inv_dt, c_h * inv_dt, c_c * inv_dt, g_w, flow_conductance(mcp, ua_jacket), g_air, g_rad,
            flow_conductance(valve * mcp, ua), winding_c, temp_c, coolant_c, q_winding_w, q_housing_w, q_inverter_w,
            ambient_c)
        on = valve > 0.0 and coolant_factor > 0.0
    else:
        q_air, q_rad, q_cool = thm.paper_node_core(g_air, eps_sigma_area, h_water_area, thermostat_c, temp_c,
                                                   ambient_c, water_c, coolant_factor)
        t_h = temp_c + (q_winding_w + q_housing_w + q_inverter_w - q_air - q_rad - q_cool) / (c_m * inv_dt)
        t_w = t_h
        t_c = coolant_c
        q_radiator = q_cool
        on = q_cool != 0.0
    return t_h, t_w, t_c, q_air, q_rad, q_cool, q_radiator, 1.0 if on else 0.0
