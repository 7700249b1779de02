"""The motor's thermal parameters and effects: the paper's eqs 1-10, for both thermal models (docs/thermal_model.md).

``ThermalParams.model``: ``"network"`` (default; ``thermal_network.py``: winding, stator/housing and a pumped coolant
loop, the paper's lumped motor temperature the stator/housing node) or ``"paper_eqs"``, the paper's node as written:
m·c_p·dT/dt = Q_gen − Q_air − Q_rad − Q_cool (eq 7), Q_air = h_air·A·(T − T_amb) (eq 1), h_air = 6 + 6·(ΔT/1000)^0.25 +
60·(V/48.27)^0.63, V in km/h (eq 4), Q_cool = h_water·A·(T − T_water) above the thermostat (eq 5, T_water held),
Q_rad = ε·σ·A·(T⁴ − T_amb⁴) in kelvin (eq 6).

Heat index (eqs 8-9): dx/dt = (T_gain/T_s)·(|T_out|/T_cont(ω) − 1), PWM = clip(x, 0, 1), available torque
T_cont·PWM + T_peak·(1 − PWM) ≤ T_peak, x held in [−PWM_initial(T), 1]; T_gain (eq 10) and PWM_initial linear in the
motor temperature. Derate −1 efficiency point per 15 °C above 35 °C (``motor.py``), cutoff at 70 °C until cooled to
60 °C, the winding's own protection (165 °C / 155 °C); ``enabled=False`` is ADVISOR's unmodified motor (the paper's
baseline). Fields whose doc starts with "fitted:" hold the values of ``python -m tools.calibration``; the two cooling
conductances are set by the motor's rating (``tools/rating.py``).
"""

from __future__ import annotations

import dataclasses
import math

from .jit import jit
from .params import Layout, Params, Slot, spec

SIGMA = 5.67e-8
KELVIN = 273.15

#: Thermal models by name; the packed ``model`` slot holds the index.
THERMAL_MODELS = ("paper_eqs", "network")
MODEL_NETWORK = 1.0


@dataclasses.dataclass(frozen=True)
class ThermalParams(Params):
    """Motor thermal model (paper's node or lumped network), heat index and protection of the traction motor."""

    model: str = spec("network", "thermal model: 'network' (motor + coolant loop + radiator, calibrated) or "
                                 "'paper_eqs' (the paper's one-node eqs 1-7 as written)")
    enabled: bool = spec(True, "thermal effects on (derate, extra loss, cutoff); False = unmodified ADVISOR motor")
    # --- the motor node (paper Table 1, eqs 1-7) ---
    mass_kg: float = spec(100.0, "thermal mass of the motor (Table 1)", min=0.0, min_exclusive=True)
    cp_j_per_kgk: float = spec(430.0, "specific heat (Table 1)", min=0.0, min_exclusive=True)
    area_m2: float = spec(0.4273, "cooling area (Table 1; ADVISOR 0.4·(m/91)^0.7)", min=0.0, min_exclusive=True)
    h_water_w_per_m2k: float = spec(3000.0, "coolant heat-transfer coefficient (paper eq 5; paper_eqs model)", min=0.0)
    thermostat_temp_c: float = spec(35.0, "coolant flows above this motor temperature (paper)")
    emissivity: float = spec(0.9, "radiation emissivity (paper eq 6)", min=0.0, max=1.0)
    cutoff_temp_c: float = spec(70.0, "the motor stops at this temperature (paper)")
    cutoff_release_temp_c: float = spec(60.0, "the motor runs again once cooled to this (hysteresis)")
    derate_start_temp_c: float = spec(35.0, "efficiency derate starts above this temperature (paper)")
    derate_frac_per_c: float = spec(0.01 / 15.0, "efficiency points lost per °C above the start (paper: 1 per 15 °C)",
                                    min=0.0, max=0.1)
    extra_loss_frac: float = spec(0.05, "extra heat as a fraction of losses: noise, friction (paper: 5 %)",
                                  min=0.0, max=1.0)
    torque_temp_coeff_per_c: float = spec(
        0.00126, "fraction of the torque envelopes lost per °C of the stator/housing node above torque_ref_temp_c: "
                 "magnet flux at fixed current (paper: NdFeB 12.6 % per 100 K; magnet datasheets 0.08-0.13 %/K)",
        min=0.0008, max=0.0013)
    torque_ref_temp_c: float = spec(20.0, "temperature of the unmodified (cold) torque envelopes (magnet data: 20 °C)")
    # --- heat index, eqs 8-10 ---
    t_s_s: float = spec(30.0, "T_s of eq 9: longest run time at peak torque (paper)", min=0.0, min_exclusive=True)
    t_gain_cold: float = spec(0.17307, "fitted: T_gain at and below t_gain_temp_lo_c (paper: T_gain in [0.1, 0.3], "
                              "varying with temperature)", min=0.1, max=0.3)
    t_gain_hot: float = spec(0.3, "T_gain at and above t_gain_temp_hi_c (paper's upper value, Fig. 4's example)",
                             min=0.1, max=0.3)
    t_gain_temp_lo_c: float = spec(35.0, "T_gain starts to rise above this (paper: its corrections act above 35 °C)")
    t_gain_temp_hi_c: float = spec(70.0, "T_gain reaches t_gain_hot here (the cutoff)")
    pwm_initial_at_ref: float = spec(0.3, "PWM_initial, the overload reserve, at and below pwm_initial_ref_temp_c "
                                          "(paper: 0.3 at its 20 °C start)", min=0.0, max=1.0)
    pwm_initial_ref_temp_c: float = spec(20.0, "the paper's start temperature")
    pwm_initial_zero_temp_c: float = spec(70.0, "PWM_initial falls linearly to 0 here: the reserve is the headroom to "
                                                "the 70 °C cutoff")
    # --- air convection, eq 4 ---
    h_air_base: float = spec(6.0, "eq 4: still-air coefficient W/(m²·K)", min=0.0)
    h_air_natural: float = spec(6.0, "eq 4: natural convection term at ΔT = 1000 K", min=0.0)
    h_air_forced: float = spec(60.0, "eq 4: forced convection at the reference speed", min=0.0)
    air_ref_speed_kmh: float = spec(48.27, "eq 4: reference air speed", min=0.0, min_exclusive=True)
    air_speed_exponent: float = spec(0.63, "eq 4: speed exponent", min=0.0)
    # --- the network (thermal_network.py); ranges and sources: docs/calibration/parameter_ranges.yaml ---
    inverter_efficiency: float = spec(0.98, "inverter efficiency: (1 − η)·|P_dc| of the mapped loss heats the "
                                            "inverter's cold plate (coolant), not the motor", min=0.97, max=0.99)
    winding_heat_capacity_j_per_k: float = spec(3300.0, "winding node: copper 5-9 kg with insulation and resin",
                                                min=2300.0, max=5700.0)
    winding_conductance_w_per_k: float = spec(30.0, "winding to stator/housing through slot liner and impregnation",
                                              min=20.0, max=100.0)
    winding_trip_temp_c: float = spec(165.0, "winding protection trips here: class 180 (H), 125 K rise (Table 1) "
                                             "over 40 °C (IEC 60034-1)")
    winding_release_temp_c: float = spec(155.0, "winding protection releases once cooled to this")
    jacket_ua_w_per_k: float = spec(1281.9, "housing-to-coolant UA of the water jacket: the paper's h_water·A (eq 5, "
                                            "3,000 W/(m²·K) × 0.4273 m²)", min=50.0, max=1282.0)
    coolant_flow_l_per_min: float = spec(12.0, "pump flow through jacket, inverter plate and valve", min=6.0, max=20.0)
    coolant_density_kg_per_l: float = spec(1.07, "50 % ethylene glycol", min=1.06, max=1.08)
    coolant_cp_j_per_kgk: float = spec(3300.0, "50 % ethylene glycol", min=3200.0, max=3500.0)
    coolant_volume_l: float = spec(10.0, "coolant in jacket, hoses and radiator", min=5.0, max=20.0)
    coolant_loop_metal_heat_capacity_j_per_k: float = spec(5600.0, "radiator, pump and pipe metal", min=2000.0,
                                                           max=10000.0)
    thermostat_band_k: float = spec(5.0, "the valve (on the coolant temperature) opens fully this much above "
                                         "thermostat_temp_c", min=2.0, max=15.0)
    radiator_ua_w_per_k: float = spec(138.0, "radiator UA at the reference face air speed, set by the rating "
                                             "(tools/rating.py): 30 kW in 40 °C air settles the housing at 90 % of "
                                             "its rise to the cut-off at 3,600 rpm (Table 1), 89.4 % at the "
                                             "envelopes' corner, 3,581 rpm", min=50.0, max=600.0)
    radiator_ref_air_speed_mps: float = spec(5.0, "face air speed of radiator_ua_w_per_k", min=3.0, max=8.0)
    radiator_air_exponent: float = spec(0.7, "UA ∝ (face air speed)^n: air-side Nusselt ∝ Re^0.5-0.8", min=0.5, max=0.8)
    ram_air_frac: float = spec(0.25, "face air speed per unit vehicle speed (ram air)", min=0.1, max=0.5)
    still_air_speed_mps: float = spec(0.5, "face air speed at standstill with the fan off", min=0.0, max=1.0)
    fan_air_speed_mps: float = spec(4.0, "face air speed of the fan at full speed", min=2.0, max=6.0)
    fan_on_temp_c: float = spec(40.0, "the fan starts at this coolant temperature", min=35.0, max=50.0)
    fan_band_k: float = spec(5.0, "the fan reaches full speed this much above fan_on_temp_c", min=2.0, max=10.0)

    def validate(self) -> None:
        self.require(self.model in THERMAL_MODELS, "model", f"{self.model!r} is not one of {list(THERMAL_MODELS)}")
        self.require(self.cutoff_release_temp_c < self.cutoff_temp_c, "cutoff_release_temp_c",
                     "must be below cutoff_temp_c")
        self.require(self.t_gain_temp_hi_c > self.t_gain_temp_lo_c, "t_gain_temp_hi_c", "must exceed t_gain_temp_lo_c")
        self.require(self.pwm_initial_zero_temp_c > self.pwm_initial_ref_temp_c, "pwm_initial_zero_temp_c",
                     "must exceed pwm_initial_ref_temp_c")
        self.require(self.winding_release_temp_c < self.winding_trip_temp_c, "winding_release_temp_c",
                     "must be below winding_trip_temp_c")
        self.require(self.winding_heat_capacity_j_per_k < 0.5 * self.heat_capacity_j_per_k,
                     "winding_heat_capacity_j_per_k", "must be below half the motor's m·c_p")
        # the paper's node is integrated explicitly: its fastest time constant must exceed the step
        tau = self.heat_capacity_j_per_k / max(self.h_water_w_per_m2k * self.area_m2, 1e-12)
        self.require(self.model != "paper_eqs" or tau >= 2.0, "h_water_w_per_m2k",
                     f"thermal time constant {tau:.2f} s is below 2 s, too stiff for the 1 s step")

    @property
    def heat_capacity_j_per_k(self) -> float:
        """Heat capacity of the motor node, m·c_p."""
        return self.mass_kg * self.cp_j_per_kgk

    @property
    def housing_heat_capacity_j_per_k(self) -> float:
        """Stator/housing node: the motor's m·c_p less the winding."""
        return self.heat_capacity_j_per_k - self.winding_heat_capacity_j_per_k

    @property
    def coolant_mcp_w_per_k(self) -> float:
        """Capacity rate ṁ·c_p of the pump's flow."""
        return self.coolant_flow_l_per_min / 60.0 * self.coolant_density_kg_per_l * self.coolant_cp_j_per_kgk

    @property
    def coolant_heat_capacity_j_per_k(self) -> float:
        """Coolant loop: the liquid and the loop's metal."""
        return (self.coolant_volume_l * self.coolant_density_kg_per_l * self.coolant_cp_j_per_kgk
                + self.coolant_loop_metal_heat_capacity_j_per_k)


LAYOUT = ThermalParams.LAYOUT = Layout.of_fields(ThermalParams, replace={
    "model": Slot("model", fill=lambda p: float(THERMAL_MODELS.index(p.model))),
}, derived={
    # constants of the per-row code, computed once here (the kernel has ~100 ns per row; a division is ~5)
    "motor_heat_capacity_j_per_k": lambda p: p.heat_capacity_j_per_k,
    "housing_heat_capacity_j_per_k": lambda p: p.housing_heat_capacity_j_per_k,
    "coolant_heat_capacity_j_per_k": lambda p: p.coolant_heat_capacity_j_per_k,
    "coolant_mcp_w_per_k": lambda p: p.coolant_mcp_w_per_k,
    "eps_sigma_area": lambda p: p.emissivity * SIGMA * p.area_m2,
    "h_water_area_w_per_k": lambda p: p.h_water_w_per_m2k * p.area_m2,
    "inv_valve_band_per_k": lambda p: 1.0 / p.thermostat_band_k,
    "inv_fan_band_per_k": lambda p: 1.0 / p.fan_band_k,
    "inv_radiator_ref_air_speed": lambda p: 1.0 / p.radiator_ref_air_speed_mps,
    "air_speed_per_mps": lambda p: 3.6 / p.air_ref_speed_kmh,
    "ram_air_per_mps": lambda p: p.ram_air_frac / p.radiator_ref_air_speed_mps,
    "still_air_term": lambda p: (p.still_air_speed_mps / p.radiator_ref_air_speed_mps) ** p.radiator_air_exponent,
    "tgain_slope_per_c": lambda p: (p.t_gain_hot - p.t_gain_cold) / (p.t_gain_temp_hi_c - p.t_gain_temp_lo_c),
    "pwm0_slope_per_c": lambda p: -p.pwm_initial_at_ref / (p.pwm_initial_zero_temp_c - p.pwm_initial_ref_temp_c),
    "inv_t_s": lambda p: 1.0 / p.t_s_s,
})  # one slot per field (the model as its index), then the derived constants
IDX = LAYOUT.index()


@jit
def _ramp(x, x_lo, x_hi, y_lo, slope):
    """y_lo up to x_lo, then rising with ``slope`` to x_hi, constant beyond (slope precomputed: no division)."""
    return y_lo + slope * (min(max(x, x_lo), x_hi) - x_lo)


@jit
def pwm_initial(th, temp_c):
    """PWM_initial, the overload reserve, of a motor at ``temp_c``: the paper's 0.3 at its 20 °C start, falling
    linearly to 0 at the 70 °C cutoff (the paper ties it to the initial temperature)."""
    return _ramp(temp_c, th[IDX.pwm_initial_ref_temp_c], th[IDX.pwm_initial_zero_temp_c], th[IDX.pwm_initial_at_ref],
                 th[IDX.pwm0_slope_per_c])


@jit
def heat_index_floor(th, temp_c):
    """Anti-windup floor of the heat-index integrator: −PWM_initial at the motor's present temperature."""
    return -pwm_initial(th, temp_c)


@jit
def t_gain(th, temp_c):
    """T_gain = f(T_mc) (eq 10), linear between the cold and hot values."""
    return _ramp(temp_c, th[IDX.t_gain_temp_lo_c], th[IDX.t_gain_temp_hi_c], th[IDX.t_gain_cold],
                 th[IDX.tgain_slope_per_c])


@jit
def derate_frac(th, temp_c):
    """Efficiency points lost (as a fraction) at ``temp_c``; 0 with the model off."""
    d = max(temp_c - th[IDX.derate_start_temp_c], 0.0) * th[IDX.derate_frac_per_c]
    return d if th[IDX.enabled] != 0.0 else 0.0


@jit
def torque_factor(th, temp_c):
    """Share of the cold torque envelopes a motor at ``temp_c`` can give (magnet remanence); 1 with the model off."""
    k = 1.0 - max(temp_c - th[IDX.torque_ref_temp_c], 0.0) * th[IDX.torque_temp_coeff_per_c]
    return max(k, 0.0) if th[IDX.enabled] != 0.0 else 1.0


@jit
def extra_loss_frac(th):
    """The extra heat as a fraction of the losses; 0 with the model off."""
    extra = th[IDX.extra_loss_frac]
    return extra if th[IDX.enabled] != 0.0 else 0.0


@jit
def heat_index_pwm(heat_x):
    """PWM = clip(x, 0, 1) (eq 9)."""
    return min(max(heat_x, 0.0), 1.0)


@jit
def available_torque_nm(th, peak_nm, cont_nm, heat_x, cutoff):
    """Torque limit under the heat index (eq 8) and the protections (``cutoff`` ≠ 0: either has tripped), never above
    the peak; the peak with the model off."""
    pwm = heat_index_pwm(heat_x)
    blended = min(cont_nm * pwm + peak_nm * (1.0 - pwm), peak_nm)
    limited = 0.0 if cutoff != 0.0 else blended
    # one return (speed rule in jit.py)
    return limited if th[IDX.enabled] != 0.0 else peak_nm


@jit
def heat_index_step(th, heat_x, heat_x_min, torque_nm, cont_nm, temp_c, dt_s):
    """One Euler step of eq 9 with anti-windup to [heat_x_min, 1]; T_gain at ``temp_c``. Beyond the maximum speed the
    continuous envelope is 0 and the motor gives no torque: the overload ratio is then 0 (the index relaxes)."""
    ratio = abs(torque_nm) / cont_nm if cont_nm > 0.0 else 0.0
    dx = t_gain(th, temp_c) * th[IDX.inv_t_s] * (ratio - 1.0)
    return min(max(heat_x + dx * dt_s, heat_x_min), 1.0)


@jit
def air_conductance_core(h_still0, h_natural, h_forced, forced_term, area, temp_c, ambient_c):
    """h_air·A of eqs 1 and 4 (W/K) from scalars, the speed's term (V/48.27)^0.63 precomputed (V in km/h)."""
    h_still = h_still0 + h_natural * math.sqrt(math.sqrt(abs(temp_c - ambient_c) * 1e-3))
    return (h_still + h_forced * forced_term) * area


@jit
def paper_node_core(g_air, eps_sigma_area, h_water_area, thermostat_c, temp_c, ambient_c, water_c, coolant_factor):
    """(Q_air, Q_rad, Q_cool) of the paper's node (eqs 1, 5, 6) from scalars; ``g_air`` = h_air·A."""
    q_air = g_air * (temp_c - ambient_c)
    q_cool = h_water_area * coolant_factor * (temp_c - water_c) if (temp_c > thermostat_c
                                                                   and coolant_factor > 0.0) else 0.0
    tk = temp_c + KELVIN
    ta = ambient_c + KELVIN
    q_rad = eps_sigma_area * ((tk * tk) * (tk * tk) - (ta * ta) * (ta * ta))
    return q_air, q_rad, q_cool


@jit
def cutoff_step(th, cutoff, temp_c):
    """Protection with hysteresis: trips at cutoff_temp_c, releases at cutoff_release_temp_c."""
    # one return, not three (speed rule in jit.py)
    tripped = temp_c >= th[IDX.cutoff_temp_c] or (cutoff != 0.0 and temp_c > th[IDX.cutoff_release_temp_c])
    return 1.0 if (th[IDX.enabled] != 0.0 and tripped) else 0.0


@jit
def winding_trip_step(th, trip, winding_c):
    """Winding protection with hysteresis: trips at winding_trip_temp_c, releases at winding_release_temp_c."""
    tripped = winding_c >= th[IDX.winding_trip_temp_c] or (trip != 0.0 and winding_c > th[IDX.winding_release_temp_c])
    return 1.0 if (th[IDX.enabled] != 0.0 and tripped) else 0.0
