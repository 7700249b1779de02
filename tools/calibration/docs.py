"""The generated tables of docs/thermal_model.md, each between ``<!-- NAME:begin -->`` and ``<!-- NAME:end -->``:
the parameter table (``params``: the protocol's rows with the code's values), the conductances and time constants
(``time-constants``), the launch check C6 (``launch``), the residual table (``residuals``) and the identifiability of
every fit attempt (``identifiability``, from docs/calibration/fit_result.json). ``python -m
tools.calibration --report-only --write-docs`` rewrites them; ``tests/test_calibration.py`` checks that the
page holds what the code gives.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from hev_thermal_env.physics import VehicleConfig, paper_bus
from hev_thermal_env.physics import thermal as thm
from hev_thermal_env.physics import thermal_network as tnet
from tools.paper.measure import LAUNCH_GRADE, LAUNCH_S, LAUNCH_SPEED_MPS, launch_run
from tools.rating import forced_air_term

from . import log
from . import protocol as proto
from . import report as residual_report
from .fit import Attempt, Start

PAGE = proto.PROTOCOL_YAML.parents[1] / "thermal_model.md"
FIT_RESULT = proto.PROTOCOL_YAML.with_name("fit_result.json")
IDX = thm.IDX


def _g(x: float) -> str:
    return f"{x:.4g}"


def params_table(config: VehicleConfig | None = None) -> list[str]:
    """Every row of the protocol's YAML: the code's value, the physical range, the status and the source."""
    config = config or paper_bus()
    lines = ["| parameter | symbol | node | value | unit | physical range | status | source |",
             "|---|---|---|---|---|---|---|---|"]
    for name, row in proto.parameters().items():
        where = proto.locate(name, config)
        value = proto.value_in_code(name, config) if where else getattr(config.thermal, name, None)
        shown = "-" if value is None else _g(value)
        rng = "-" if row["min"] == row["max"] else f"[{_g(row['min'])}, {_g(row['max'])}]"
        status = {"fitted": f"**fitted** (start {_g(row['value'])})", "derived": f"derived: {row.get('formula', '')}"}
        code = f"`{where[0]}.{where[1]}`" if where else "(property)"
        lines.append(f"| {code} | {row['symbol']} | {row['node']} | {shown} | {row['unit']} | {rng} | "
                     f"{status.get(row['status'], 'fixed')} | {row['source']} |")
    return lines


def conductances(config: VehicleConfig, speed_mps: float, housing_c: float, coolant_c: float,
                 ambient_c: float = 20.0, coolant_factor: float = 1.0, fan_factor: float = 1.0) -> dict[str, float]:
    """The network's conductances (W/K) at an operating point, from the physics' own functions."""
    th = config.thermal.pack()
    forced = forced_air_term(th[IDX.air_speed_per_mps], th[IDX.air_speed_exponent], speed_mps)
    g_air = thm.air_conductance_core(th[IDX.h_air_base], th[IDX.h_air_natural], th[IDX.h_air_forced], forced,
                                     th[IDX.area_m2], housing_c, ambient_c)
    mcp = th[IDX.coolant_mcp_w_per_k] * coolant_factor
    valve = min(max((coolant_c - th[IDX.thermostat_temp_c]) * th[IDX.inv_valve_band_per_k], 0.0), 1.0)
    ram = (th[IDX.ram_air_per_mps] * speed_mps) ** th[IDX.radiator_air_exponent] if speed_mps > 0 else 0.0
    ua = tnet.radiator_core(th[IDX.radiator_ua_w_per_k], ram, th[IDX.still_air_term],
                            th[IDX.inv_radiator_ref_air_speed], th[IDX.radiator_air_exponent],
                            th[IDX.fan_air_speed_mps], th[IDX.fan_on_temp_c], th[IDX.inv_fan_band_per_k], coolant_c,
                            fan_factor)
    return {"G_w": th[IDX.winding_conductance_w_per_k], "G_air": g_air,
            "G_rad": tnet._radiation_conductance(th[IDX.eps_sigma_area], housing_c, ambient_c),
            "G_hc": tnet.flow_conductance(mcp, th[IDX.jacket_ua_w_per_k]), "valve": valve,
            "G_r": tnet.flow_conductance(valve * mcp, ua)}


#: Operating points of the time-constant table: (label, speed m/s, housing °C, coolant °C, coolant factor).
OPERATING_POINTS = (
    ("coolant on, valve closed (T_c ≤ 35 °C), standstill", 0.0, 35.0, 30.0, 1.0),
    ("coolant on, valve open, fan off (T_c = 40 °C), standstill", 0.0, 45.0, 40.0, 1.0),
    ("coolant on, valve open, fan full (T_c = 45 °C), standstill", 0.0, 50.0, 45.0, 1.0),
    ("coolant on, valve open, fan off (T_c = 40 °C), 50 km/h", 50 / 3.6, 45.0, 40.0, 1.0),
    ("coolant closed, standstill", 0.0, 45.0, 45.0, 0.0),
    ("coolant closed, 50 km/h", 50 / 3.6, 45.0, 45.0, 0.0),
)


def time_constants_table(config: VehicleConfig | None = None) -> list[str]:
    """Per operating point: the conductances, each node's time constant with its neighbours held (C / ΣG) and the
    network's three modes (1/eigenvalues of C⁻¹K, the linearised conduction matrix), ambient 20 °C."""
    config = config or paper_bus()
    th = config.thermal
    caps = np.array([th.winding_heat_capacity_j_per_k, th.housing_heat_capacity_j_per_k,
                     th.coolant_heat_capacity_j_per_k])
    lines = [f"Heat capacities: winding C_w = {_g(caps[0])} J/K, stator/housing C_h = {_g(caps[1])} J/K, coolant "
             f"loop C_c = {_g(caps[2])} J/K; pump ṁc_p = {_g(th.coolant_mcp_w_per_k)} W/K.", "",
             "| operating point | G_w | G_air + G_rad | G_hc | G_r | τ_w | τ_h | τ_c | network modes |",
             "|---|---|---|---|---|---|---|---|---|"]
    for label, v, t_h, t_c, f_c in OPERATING_POINTS:
        g = conductances(config, v, t_h, t_c, coolant_factor=f_c)
        g_a = g["G_air"] + g["G_rad"]
        k = np.array([[g["G_w"], -g["G_w"], 0.0], [-g["G_w"], g["G_w"] + g_a + g["G_hc"], -g["G_hc"]],
                      [0.0, -g["G_hc"], g["G_hc"] + g["G_r"]]])
        lam = np.sort(np.linalg.eigvals(k / caps[:, None]).real)
        modes = ", ".join(_duration(1.0 / x) if x > 1e-12 else "∞" for x in lam[::-1])
        tau_c = _duration(caps[2] / (g["G_hc"] + g["G_r"])) if g["G_hc"] + g["G_r"] > 0 else "∞ (no flow)"
        lines.append(f"| {label} | {_g(g['G_w'])} | {g_a:.1f} | {g['G_hc']:.0f} | {g['G_r']:.0f} | "
                     f"{_duration(caps[0] / g['G_w'])} | {_duration(caps[1] / (g['G_w'] + g_a + g['G_hc']))} | "
                     f"{tau_c} | {modes} |")
    lines += ["", "Conductances in W/K; τ of a node with its neighbours held at their temperatures; the modes are "
              "the coupled network's (fastest first)."]
    return lines


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "∞"
    return f"{seconds:.0f} s" if seconds < 600 else f"{seconds / 60:.0f} min" if seconds < 3 * 3600 \
        else f"{seconds / 3600:.1f} h"


def launch_lines(config: VehicleConfig | None = None) -> list[str]:
    config = config or paper_bus()
    run = launch_run(config)
    cont_nm = config.motor.continuous_torque_nm
    return [f"From the steady state at the continuous torque ({cont_nm:.0f} N·m at "
            f"{run['speed_radps'][0] * 30 / math.pi:.0f} rpm, {cont_nm * run['speed_radps'][0] / 1e3:.1f} kW, not the "
            f"rated 30 kW: {LAUNCH_SPEED_MPS} m/s on a {100 * LAUNCH_GRADE:.0f} % grade, first gear; steady after "
            f"{run['warm_s'] / 3600:.1f} h): winding {run['winding_c'][0]:.1f} °C, "
            f"{run['winding_over_housing_start_k']:.1f} K above the housing ({run['housing_c'][0]:.1f} °C), coolant "
            f"{run['coolant_c'][0]:.1f} °C. {LAUNCH_S} s at "
            f"peak torque ({run['torque_nm'][0]:.1f} N·m: 240 N·m less the magnets' coefficient at the housing's "
            f"temperature) raise the winding by **{run['winding_rise_k']:+.1f} K** to {run['winding_c'][-1]:.1f} °C "
            f"({run['winding_over_housing_end_k']:.1f} K above the housing, which gains "
            f"{run['housing_c'][-1] - run['housing_c'][0]:+.2f} K)."]


def residual_lines(config: VehicleConfig | None = None) -> list[str]:
    report = residual_report.build(config)
    return [*residual_report.residual_table(report), "", residual_report.summary_line(report), "",
            *residual_report.checks_table(report)]


def _attempts(path: Path = FIT_RESULT) -> list[Attempt]:
    data = json.loads(path.read_text())
    return [Attempt(**{**a, "starts": [Start(**s) for s in a["starts"]]}) for a in data]


def identifiability_lines(path: Path = FIT_RESULT) -> list[str]:
    lines = []
    for i, a in enumerate(_attempts(path), 1):
        values = ", ".join(f"`{n}` = {_g(a.values[n])}" for n in a.free) or "none free"
        lines += [f"**Attempt {i}: {a.label}** ({'adopted' if a.adopted else 'not adopted'}): {values}; "
                  f"Σr² = {a.cost:.2f} over F1-F7. {a.note[0].upper() + a.note[1:]}.", "",
                  *log.identifiability_lines(a), "", *log.profile_lines(a), ""]
    return lines[:-1]


BLOCKS: dict[str, Callable[[], list[str]]] = {
    "params": params_table, "time-constants": time_constants_table, "launch": launch_lines,
    "residuals": residual_lines, "identifiability": identifiability_lines,
}


def block_pattern(name: str) -> re.Pattern:
    return re.compile(rf"(<!-- {name}:begin -->\n)(.*?)(<!-- {name}:end -->)", re.S)


def render(text: str, blocks: dict[str, list[str]]) -> str:
    """``text`` with each named block's body replaced."""
    for name, lines in blocks.items():
        pattern = block_pattern(name)
        if not pattern.search(text):
            raise ValueError(f"{PAGE}: no '<!-- {name}:begin -->' ... '<!-- {name}:end -->' block")
        body = "\n".join(lines)
        text = pattern.sub(lambda m, body=body: m.group(1) + body + "\n" + m.group(3), text)
    return text


def generated(names: tuple[str, ...] = tuple(BLOCKS)) -> dict[str, list[str]]:
    return {n: BLOCKS[n]() for n in names}


def write(path: Path = PAGE) -> Path:
    path.write_text(render(path.read_text(), generated()))
    return path


def page_blocks(path: Path = PAGE) -> dict[str, str]:
    """The bodies of the page's generated blocks, as they stand."""
    text = path.read_text()
    return {n: m.group(2).rstrip("\n") for n in BLOCKS if (m := block_pattern(n).search(text))}
