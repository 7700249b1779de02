"""The one physics step of the vehicle, vectorised over a batch axis (docs/vehicle.md, docs/architecture.md).

``step_kernel`` advances B independent vehicles by one step: the only place where the components are put together,
called through :class:`PhysicsCore` by everything that steps a vehicle. Backward-facing and quasi-static (ADVISOR):
the road load at the mean of the cycle's speeds v0 → v1 gives the wheel torque, the driveline maps it to the coupler
shaft, the action u ∈ [-1, 1] splits it. Traction: the motor is asked for u·T_dem, clipped only by its own limits
(peak torque, the heat index of eq 8, the protections) and the battery's power and SOC limits; the engine covers the
rest up to full load; what is still missing is a trace miss (missed wheel energy; ``trace_miss_mps`` = missed
force·dt / effective mass; why the motor never tops up: docs/vehicle.md). Braking: the driven axle takes a
speed-dependent share (``glider.driven_axle_brake_frac``), the other axle's friction brakes the rest; of its available
regeneration the motor takes the share u > 0 (u ≤ 0: friction alone). u = 0 throughout is the bus with its motor
unused (the spinning motor's losses remain); at standstill the action has no effect.
"""

from __future__ import annotations

import math

import numpy as np

from . import battery as bat
from . import driveline as drv
from . import engine as eng
from . import glider as gli
from . import motor as mot
from . import thermal as thm
from . import thermal_network as tnet
from .config import ENGINE_OFF_TOL, PT_IDX, Conditions, VehicleConfig
from .jit import MIN_THREAD_BATCH, jit, thread_pool

# state columns (``motor_temp_c``: the stator/housing node, the paper's lumped motor temperature; ``heat_x_min``: the
# heat index's anti-windup floor, −PWM_initial at that temperature; ``motor_cutoff``: the 70 °C protection; the winding
# and coolant nodes: the paper's model holds them at the motor's and the run's water temperature)
SOC, TEMP_C, HEAT_X, HEAT_X_MIN, CUTOFF, WINDING_C, COOLANT_C, WINDING_TRIP = range(8)
N_STATE = 8
STATE_NAMES = ("soc", "motor_temp_c", "heat_x", "heat_x_min", "motor_cutoff", "winding_temp_c", "coolant_temp_c",
               "winding_trip")

# condition columns (``water_c``: the coolant's start, and the paper's perfect-radiator water temperature;
# ``coolant_factor``: 1 on, < 1 degraded, 0 off; ``fan_factor``: 1 the radiator fan works, 0 it has failed)
AMBIENT_C, WATER_C, COOLANT_FACTOR, PAYLOAD_KG, FAN_FACTOR, ACCESSORY_W = range(6)
N_COND = 6

# output columns (per step; powers are means over the step, energies in J)
OUT_NAMES = (
    "fuel_g", "engine_on", "engine_speed_radps", "engine_torque_nm", "engine_power_w", "motor_torque_nm",
    "motor_speed_radps", "motor_elec_power_w", "motor_loss_w", "motor_heat_w", "motor_torque_avail_nm",
    "motor_torque_request_nm", "battery_power_w", "battery_chem_power_w", "battery_loss_w", "battery_current_a", "gear",
    "speed_mps", "wheel_power_demand_w", "wheel_power_w", "missed_wheel_energy_j", "trace_miss_mps", "brake_power_w",
    "clutch_loss_w", "driveline_loss_w", "accessory_power_w", "coolant_on", "heat_index", "q_air_w", "q_rad_w",
    "q_cool_w", "shaft_torque_demand_nm", "motor_torque_clipped", "engine_torque_max_nm", "motor_torque_max_nm",
    "q_radiator_w", "inverter_heat_w", "regen_available_nm",
)
(FUEL_G, ENGINE_ON, ENGINE_SPEED, ENGINE_TORQUE, ENGINE_POWER, MOTOR_TORQUE, MOTOR_SPEED, MOTOR_ELEC, MOTOR_LOSS,
 MOTOR_HEAT, MOTOR_AVAIL, MOTOR_REQ, BATT_POWER, BATT_CHEM, BATT_LOSS, BATT_CURRENT, GEAR, SPEED, WHEEL_DEMAND,
 WHEEL_POWER, MISSED_J, TRACE_MISS, BRAKE_POWER, CLUTCH_LOSS, DRIVELINE_LOSS, ACC, COOLANT_ON, HEAT_INDEX, Q_AIR, Q_RAD,
 Q_COOL, SHAFT_DEMAND, MOTOR_CLIPPED, ENGINE_MAX, MOTOR_MAX, Q_RADIATOR, INVERTER_HEAT, REGEN_AVAIL) = range(38)
N_OUT = len(OUT_NAMES)


@jit
def step_kernel(gl, dl, en, mo, th, ba, pt, state, action, v0, v1, grade, cond, dt, state_out, out):
    """Advance every row of ``state`` [B, N_STATE] by one step; write ``state_out`` and ``out`` [B, N_OUT].

    ``action``, ``v0``, ``v1``, ``grade`` have length B; ``cond`` is [B, N_COND]. One loop indexing the 2-D arrays by
    ``b``, with no per-row view and no per-row call taking a parameter vector: the speed rule of ``jit.py``.
    """
    inv_dt = 1.0 / dt
    # the speed's factors of the thermal model, recomputed only when the speed changes from the previous row
    log_air_per_mps, air_exp = math.log(th[thm.IDX.air_speed_per_mps]), th[thm.IDX.air_speed_exponent]
    log_ram_per_mps, ram_exp = math.log(th[thm.IDX.ram_air_per_mps]), th[thm.IDX.radiator_air_exponent]
    network = th[thm.IDX.model] == thm.MODEL_NETWORK
    v_memo = -1.0
    forced_term = 0.0
    ram_term = 0.0
    for b in range(action.shape[0]):
        # --- one row ---------------------------------------------------------------------------
        soc = state[b, SOC]
        temp = state[b, TEMP_C]
        hx = state[b, HEAT_X]
        cutoff = state[b, CUTOFF]
        winding = state[b, WINDING_C]
        coolant = state[b, COOLANT_C]
        motor_off = 1.0 if (cutoff != 0.0 or state[b, WINDING_TRIP] != 0.0) else 0.0
        ambient = cond[b, AMBIENT_C]
        water = cond[b, WATER_C]
        coolant_factor = cond[b, COOLANT_FACTOR]
        payload = cond[b, PAYLOAD_KG]
        fan_factor = cond[b, FAN_FACTOR]
        acc_w = cond[b, ACCESSORY_W]
        stop_start = pt[PT_IDX.stop_start] != 0.0
        u = min(max(action[b], -1.0), 1.0)
        v_start = v0[b]
        v_end = v1[b]
        slope = grade[b]

        # --- road load and driveline -------------------------------------------------------------
        v = 0.5 * (v_start + v_end)
        accel = (v_end - v_start) / dt
        moving = v > 1e-6
        force = gli.road_force_n(gl, v, accel, slope, payload) if moving else 0.0
        r_w = gl[gli.IDX.wheel_radius_m]
        t_wheel = force * r_w
        w_wheel = v / r_w
        p_eng_max = en[eng.IDX.max_power_w]
        gear = drv.select_gear(dl, w_wheel, force * v / max(p_eng_max, 1.0), en[eng.IDX.max_speed_radps])
        w_s = w_wheel * drv.overall_ratio(dl, gear)
        t_s_dem = drv.shaft_torque_nm(dl, t_wheel, gear) if moving else 0.0
        rho = dl[drv.IDX.coupler_ratio]
        w_m = w_s * rho

        # --- motor envelope at the start of the step ------------------------------------------------
        extra = thm.extra_loss_frac(th)
        derate = thm.derate_frac(th, temp)
        k_temp = thm.torque_factor(th, temp)
        t_env = thm.available_torque_nm(th, k_temp * mot.peak_torque_nm(mo, w_m),
                                        k_temp * mot.continuous_torque_nm(mo, w_m), hx, motor_off)
        p_dis, p_chg = bat.power_limits_w(ba, soc, dt)
        engine_avail = w_s <= en[eng.IDX.max_speed_radps] + 1e-9

        t_m = 0.0
        t_e = 0.0
        w_e = 0.0
        t_acc = 0.0
        fuel_rate = 0.0
        clutch_loss = 0.0
        brake_w = 0.0
        missed_force = 0.0
        t_m_req = 0.0
        t_e_max = 0.0
        t_m_max = 0.0
        regen_avail = 0.0

        if t_s_dem > 0.0:
            # --- traction: motor request clipped to its limits, engine covers the rest -------------------
            band = pt[PT_IDX.engine_min_share]  # the engine-off band (PowertrainParams.engine_off_from)
            u = 1.0 if stop_start and band > 0.0 and u >= 1.0 - band - ENGINE_OFF_TOL else u
            engine_on = engine_avail and (((1.0 - u) * t_s_dem > 1e-9) or not stop_start)
            if not engine_on and engine_avail and p_dis < acc_w:
                engine_on = True  # the battery cannot carry the accessories
            acc_elec = 0.0 if engine_on else acc_w
            t_lo, t_hi = mot.torque_limits_for_power(mo, w_m, p_dis - acc_elec, p_chg + acc_elec, extra, derate, t_env)
            t_m_min = max(-t_env, t_lo)
            t_m_max = min(t_env, t_hi)
            t_m_req = u * t_s_dem / rho
            t_m = min(max(t_m_req, t_m_min), t_m_max)
            t_e = t_s_dem - rho * t_m
            if t_e > 1e-9 and not engine_on and engine_avail:
                engine_on = True
                t_lo, t_hi = mot.torque_limits_for_power(mo, w_m, p_dis, p_chg, extra, derate, t_env)
                t_m_min = max(-t_env, t_lo)
                t_m_max = min(t_env, t_hi)
                t_m = min(max(t_m, t_m_min), t_m_max)
                t_e = t_s_dem - rho * t_m
            if engine_on:
                w_e = max(w_s, en[eng.IDX.idle_speed_radps])
                t_acc = acc_w / w_e
                t_e_max = max(eng.max_torque_nm(en, w_e) - t_acc, 0.0)
            t_e = min(max(t_e, 0.0), t_e_max)
            short = t_s_dem - rho * t_m - t_e
            if short > 1e-12 and t_m < 0.0 and pt[PT_IDX.charge_yields_to_demand] != 0.0:  # the charge yields
                t_m = min(t_m + short / rho, 0.0, t_m_max)
                t_e = min(max(t_s_dem - rho * t_m, 0.0), t_e_max)
                short = t_s_dem - rho * t_m - t_e
            if short > 1e-12:
                missed_force = (t_wheel - drv.wheel_torque_nm(dl, rho * t_m + t_e, gear)) / r_w
            if engine_on:
                clutch_loss = t_e * (w_e - w_s)
                fuel_rate = eng.fuel_rate_gps(en, w_e, t_e + t_acc)
            t_s_used = rho * t_m + t_e
            t_w_used = drv.wheel_torque_nm(dl, t_s_used, gear)
            driveline_loss = t_s_used * w_s - t_w_used * w_wheel
        else:
            # --- braking, coasting or standstill: the action's share of the available regeneration ------
            engine_on = not stop_start
            if not engine_on and p_dis < acc_w and engine_avail:
                engine_on = True
            acc_take = 0.0
            if engine_on:
                w_e = max(w_s, en[eng.IDX.idle_speed_radps])
                if moving and w_s >= en[eng.IDX.idle_speed_radps]:
                    # overrun: fuel cut; the braking shaft drives the accessories as far as it can
                    acc_take = min(acc_w, -t_s_dem * w_s)
                acc_from_engine = acc_w - acc_take
                t_acc = acc_from_engine / w_e
                t_e_max = max(eng.max_torque_nm(en, w_e) - acc_w / w_e, 0.0)
                fuel_rate = eng.fuel_rate_gps(en, w_e, t_acc) if acc_from_engine > 1e-9 else 0.0
            acc_elec = 0.0 if engine_on else acc_w
            t_lo, t_hi = mot.torque_limits_for_power(mo, w_m, p_dis - acc_elec, p_chg + acc_elec, extra, derate, t_env)
            t_m_max = min(t_env, t_hi)
            t_s_free = t_s_dem + (acc_take / w_s if acc_take > 0.0 else 0.0)
            if pt[PT_IDX.regen_enabled] != 0.0 and t_s_free < 0.0:
                axle = gli.driven_axle_brake_frac(gl, v) * t_s_free / rho
                regen_avail = max(axle, max(-t_env, t_lo))
                share = max(u, 0.0)
                t_m_req = share * axle
                t_m = share * regen_avail
            t_m = min(t_m, t_hi)  # an empty battery: the motor's spinning loss brakes the shaft
            t_s_used = rho * t_m - (acc_take / w_s if acc_take > 0.0 else 0.0)
            if moving and engine_on and t_s_used < t_s_dem:
                # that drag beyond the braking asked for: the running engine turns the motor
                t_e = t_s_dem - t_s_used
                fuel_rate = eng.fuel_rate_gps(en, w_e, t_e + t_acc)
                clutch_loss = t_e * (w_e - w_s)
                t_s_used = t_s_dem
            t_w_used = drv.wheel_torque_nm(dl, t_s_used, gear)
            brake_w = -(t_wheel - t_w_used) * w_wheel if moving else 0.0
            if brake_w < 0.0:  # braked harder than asked (the engine cannot turn the motor): a trace miss
                missed_force = -brake_w / max(v, 1e-9)
                brake_w = 0.0
            driveline_loss = t_s_used * w_s - t_w_used * w_wheel

        # --- motor, battery ---------------------------------------------------------------------------
        motor_loss = mot.total_loss_w(mo, t_m, w_m, extra, derate)
        p_elec = t_m * w_m + motor_loss  # = mot.electric_power_w (0 without a motor: its torque and loss are 0)
        acc_elec = 0.0 if engine_on else acc_w
        p_batt = p_elec + acc_elec
        current = bat.current_a(ba, soc, p_batt)
        voc = bat.open_circuit_voltage_v(ba, soc)
        # chemical power released (> 0) or stored (< 0): a charging current stores its coulombic efficiency's share
        p_chem = voc * current if current >= 0.0 else voc * current * ba[bat.IDX.coulombic_efficiency]
        soc_new = bat.soc_step(ba, soc, current, dt)

        # --- thermal: temperatures (paper's eq 7 or the network), heat index (eq 9), protections --------
        # the mapped loss (motor and inverter) split between winding, housing and the inverter's cold plate
        q_core = (1.0 + extra) * mot.core_loss_w(mo, w_m)
        q_winding, q_housing, q_inverter, heat_w = tnet.split_loss_w(motor_loss, p_elec, q_core,
                                                                     th[thm.IDX.inverter_efficiency], network)
        if v != v_memo:  # (k·v)^n = exp(n·(log k + log v)): one logarithm for both factors
            v_memo = v
            log_v = math.log(v) if v > 0.0 else 0.0
            forced_term = math.exp(air_exp * (log_air_per_mps + log_v)) if v > 0.0 else 0.0
            ram_term = math.exp(ram_exp * (log_ram_per_mps + log_v)) if (v > 0.0 and network) else 0.0
        temp_new, winding_new, coolant_new, q_air, q_rad, q_cool, q_radiator, coolant_on = tnet.thermal_step(
            th, temp, winding, coolant, q_winding, q_housing, q_inverter, ambient, water, coolant_factor,
            fan_factor, forced_term, ram_term, inv_dt)
        cont = mot.continuous_torque_nm(mo, w_m)
        hx_min_new = thm.heat_index_floor(th, temp_new)  # the floor follows the motor's temperature
        hx_new = thm.heat_index_step(th, hx, hx_min_new, t_m, cont, temp, dt)
        cutoff_new = thm.cutoff_step(th, cutoff, temp_new)
        trip_new = thm.winding_trip_step(th, state[b, WINDING_TRIP], winding_new)

        state_out[b, SOC] = soc_new
        state_out[b, TEMP_C] = temp_new
        state_out[b, HEAT_X] = hx_new
        state_out[b, HEAT_X_MIN] = hx_min_new
        state_out[b, CUTOFF] = cutoff_new
        state_out[b, WINDING_C] = winding_new
        state_out[b, COOLANT_C] = coolant_new
        state_out[b, WINDING_TRIP] = trip_new

        m_eff = gli.effective_mass_kg(gl, payload)
        out[b, FUEL_G] = fuel_rate * dt
        out[b, ENGINE_ON] = 1.0 if engine_on else 0.0
        out[b, ENGINE_SPEED] = w_e
        out[b, ENGINE_TORQUE] = t_e
        out[b, ENGINE_POWER] = (t_e + t_acc) * w_e
        out[b, MOTOR_TORQUE] = t_m
        out[b, MOTOR_SPEED] = w_m
        out[b, MOTOR_ELEC] = p_elec
        out[b, MOTOR_LOSS] = motor_loss
        out[b, MOTOR_HEAT] = heat_w
        out[b, MOTOR_AVAIL] = t_env
        out[b, MOTOR_REQ] = t_m_req
        out[b, BATT_POWER] = p_batt
        out[b, BATT_CHEM] = p_chem
        out[b, BATT_LOSS] = p_chem - p_batt
        out[b, BATT_CURRENT] = current
        out[b, GEAR] = gear + 1
        out[b, SPEED] = v_end - missed_force * dt / m_eff
        out[b, WHEEL_DEMAND] = force * v
        out[b, WHEEL_POWER] = (force - missed_force) * v
        out[b, MISSED_J] = missed_force * v * dt
        out[b, TRACE_MISS] = missed_force * dt / m_eff
        out[b, BRAKE_POWER] = brake_w
        out[b, CLUTCH_LOSS] = clutch_loss
        out[b, DRIVELINE_LOSS] = driveline_loss
        out[b, ACC] = acc_w
        out[b, COOLANT_ON] = coolant_on
        out[b, HEAT_INDEX] = thm.heat_index_pwm(hx_new)
        out[b, Q_AIR] = q_air
        out[b, Q_RAD] = q_rad
        out[b, Q_COOL] = q_cool
        out[b, SHAFT_DEMAND] = t_s_dem
        out[b, MOTOR_CLIPPED] = 1.0 if abs(t_m - t_m_req) > 1e-6 else 0.0
        out[b, ENGINE_MAX] = t_e_max
        out[b, MOTOR_MAX] = t_m_max
        out[b, Q_RADIATOR] = q_radiator
        out[b, INVERTER_HEAT] = q_inverter
        out[b, REGEN_AVAIL] = regen_avail


class PhysicsCore:
    """The only door to the physics kernel: a vehicle's packed parameters and the batched step.

    >>> core = PhysicsCore(paper_bus())
    >>> state = core.initial_state(Conditions(), batch=4)
    >>> new_state, out = core.step(state, action=np.zeros(4), speed_start_mps=np.zeros(4),
    ...                            speed_end_mps=np.ones(4), grade=0.0, cond=core.conditions_array(Conditions(), 4))
    """

    def __init__(self, config: VehicleConfig, dt_s: float = 1.0):
        self.config, self.dt_s = config, float(dt_s)
        #: The packed parameter vectors, in the kernel's argument order.
        self.params = tuple(p.pack() for p in (config.glider, config.driveline, config.engine, config.motor,
                                                config.thermal, config.battery, config.powertrain))
        self.gl, self.dl, self.en, self.mo, self.th, self.ba, self.pt = self.params

    def initial_state(self, conditions: Conditions, batch: int = 1) -> np.ndarray:
        conditions.check_soc(self.config.battery)
        t0, th = conditions.initial_motor_temp_c, self.config.thermal
        st = np.zeros((batch, N_STATE))
        st[:, SOC] = conditions.initial_soc
        st[:, TEMP_C] = st[:, WINDING_C] = t0
        st[:, HEAT_X] = st[:, HEAT_X_MIN] = thm.heat_index_floor(self.th, t0)
        st[:, CUTOFF] = float(th.enabled and t0 >= th.cutoff_temp_c)
        st[:, COOLANT_C] = conditions.water_temp_c
        st[:, WINDING_TRIP] = float(th.enabled and t0 >= th.winding_trip_temp_c)
        return st

    @staticmethod
    def conditions_array(conditions: Conditions, batch: int = 1) -> np.ndarray:
        cond = np.empty((batch, N_COND))
        cond[:, AMBIENT_C] = conditions.ambient_temp_c
        cond[:, WATER_C] = conditions.water_temp_c
        cond[:, COOLANT_FACTOR] = conditions.coolant_factor
        cond[:, PAYLOAD_KG] = conditions.payload_kg
        cond[:, FAN_FACTOR] = 1.0 if conditions.fan else 0.0
        cond[:, ACCESSORY_W] = conditions.accessory_power_w
        return cond

    def step_unchecked(self, state, action, v0, v1, grade, cond, state_out, out) -> None:
        """:meth:`step` on one thread without its checks: every array already float64, C-contiguous, of B rows."""
        step_kernel(*self.params, state, action, v0, v1, grade, cond, self.dt_s, state_out, out)

    def step(self, state, action, speed_start_mps, speed_end_mps, grade, cond, *, state_out=None, out=None,
             threads: int = 1):
        """Advance a batch of B vehicles by one step; returns (new state [B, N_STATE], outputs [B, N_OUT]).

        ``action`` (the motor share u), ``speed_start_mps``, ``speed_end_mps`` and ``grade``: [B] or scalars;
        ``cond`` [B, N_COND] or [N_COND]. Every input reaches the kernel as a float64 C-contiguous array (one
        compiled specialisation); a bad shape raises a ``ValueError`` naming the argument. ``state_out``/``out``
        (float64, C-contiguous) are filled if given. ``threads`` > 1 splits batches of at least
        :data:`~.jit.MIN_THREAD_BATCH` rows over that many threads (the kernel releases the GIL).
        """
        state = _as_float64(state, "state")
        if state.ndim != 2 or state.shape[1] != N_STATE:
            raise ValueError(f"PhysicsCore.step: state must have shape (B, {N_STATE}), got {state.shape}")
        b = state.shape[0]
        action, v0, v1, grade = (_as_batch(x, b, name) for x, name in (
            (action, "action"), (speed_start_mps, "speed_start_mps"), (speed_end_mps, "speed_end_mps"),
            (grade, "grade")))
        cond = _as_float64(cond, "cond")
        if cond.shape == (N_COND,):
            cond = np.ascontiguousarray(np.broadcast_to(cond, (b, N_COND)))
        if cond.shape != (b, N_COND):
            raise ValueError(f"PhysicsCore.step: cond must have shape ({b}, {N_COND}), got {cond.shape}")
        state_out = _checked_out(state_out, (b, N_STATE), "state_out")
        out = _checked_out(out, (b, N_OUT), "out")
        n = max(1, int(threads))
        if n == 1 or b < MIN_THREAD_BATCH:
            self.step_unchecked(state, action, v0, v1, grade, cond, state_out, out)
            return state_out, out
        edges = np.linspace(0, b, n + 1).astype(int)

        def run(j: int) -> None:
            s = slice(edges[j], edges[j + 1])
            self.step_unchecked(state[s], action[s], v0[s], v1[s], grade[s], cond[s], state_out[s], out[s])

        list(thread_pool(n).map(run, range(n)))
        return state_out, out


def _as_float64(x, name: str) -> np.ndarray:
    try:
        return np.ascontiguousarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"PhysicsCore.step: {name} must be numeric, got {type(x).__name__}") from None


def _as_batch(x, b: int, name: str) -> np.ndarray:
    a = _as_float64(x, name)
    if a.shape == (b,):
        return a
    if a.ndim == 0 or a.shape == (1,):
        return np.full(b, float(a.reshape(-1)[0]))
    raise ValueError(f"PhysicsCore.step: {name} must be a scalar or have shape ({b},), got {a.shape}")


def _checked_out(x: np.ndarray | None, shape: tuple[int, int], name: str) -> np.ndarray:
    """``x``, or a new array of ``shape`` if None."""
    if x is None:
        return np.empty(shape)
    if not (isinstance(x, np.ndarray) and x.dtype == np.float64 and x.flags.c_contiguous and x.shape == shape):
        raise ValueError(f"PhysicsCore.step: {name} must be a C-contiguous float64 array of shape {shape}")
    return x
