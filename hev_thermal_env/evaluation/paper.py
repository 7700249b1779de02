"""The paper reproduction report: our results beside the paper's Tables 2-3 and Figs. 4, 7-10.

``python evaluate.py paper --out DIR`` writes ``DIR/report.md``, ``DIR/paper.json`` and PNG figures.
Every section states where ours differs from the paper and why.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.io import atomic_write_json, atomic_write_text, check_writable_dir, save_png
from hev_thermal_env.physics import Conditions, ThermalParams, paper_bus
from hev_thermal_env.physics import motor as mot
from hev_thermal_env.physics import thermal as thm
from hev_thermal_env.physics.performance import acceleration_time_s, max_sustained_speed_kmh

from .plots import pyplot
from .runner import run_strategy

RPM = math.pi / 30.0

PAPER_TABLE3 = {  # thermal off, thermal at 30 °C start, thermal at 50 °C start (coolant closed)
    "top_speed_kmh": (89.0, 89.0, 89.0),
    "accel_0_60_s": (16.4, 16.8, 17.1),
    "grade_4pct_speed_kmh": (48.3, 48.3, 48.3),
}
TABLE3_TOLERANCE = {"top_speed_kmh": 0.05, "accel_0_60_s": 0.07, "grade_4pct_speed_kmh": 0.07}
PAPER_TABLE2 = {"hwfet": (35.3, 35.6), "beijing": (27.1, 27.1)}  # L/100 km without / with thermal model


def table3(resolution_kmh: float = 0.05, accel_dt_s: float = 0.1) -> dict[str, Any]:
    """Table 3 analog: top speed, 0-60 km/h, 4 % grade; thermal off vs on at 30 and 50 °C, coolant off."""
    cfg = paper_bus()
    runs = {"thermal_off": (cfg.with_thermal(False), Conditions(coolant="off")),
            "thermal_30c": (cfg, Conditions(initial_motor_temp_c=30.0, coolant="off")),
            "thermal_50c": (cfg, Conditions(initial_motor_temp_c=50.0, coolant="off"))}
    out: dict[str, Any] = {}
    for key, (c, cond) in runs.items():
        out[key] = {"top_speed_kmh": max_sustained_speed_kmh(c, 0.0, resolution_kmh),
                    "accel_0_60_s": float(acceleration_time_s(c, cond, dt_s=accel_dt_s)),
                    "grade_4pct_speed_kmh": max_sustained_speed_kmh(c, 0.04, resolution_kmh)}
    out["within_tolerance"] = {k: abs(out["thermal_off"][k] / PAPER_TABLE3[k][0] - 1) <= TABLE3_TOLERANCE[k]
                               for k in PAPER_TABLE3}
    return out


def fig4(out_dir: Path) -> dict[str, Any]:
    """Fig. 4 analog: heat index at twice the continuous torque from cold (T_gain 0.3, T_s 30 s, PWM_initial 0.3)."""
    th = ThermalParams(t_gain_cold=0.3, t_gain_hot=0.3, pwm_initial_cold=0.3).pack()
    mo = paper_bus().motor.pack()
    w = 2000 * RPM
    cont, peak = mot.continuous_torque_nm(mo, w), mot.peak_torque_nm(mo, w)
    x = -thm.pwm_initial(th, 20.0)
    x_min = x
    t_s = np.arange(0, 201)
    pwm, tmax = [], []
    for _ in t_s:
        pwm.append(thm.heat_index_pwm(x))
        tmax.append(thm.available_torque_nm(th, peak, cont, x, 0.0))
        x = thm.heat_index_step(th, x, x_min, 2.0 * cont, cont, 20.0, 1.0)
    pwm = np.array(pwm)
    leave = float(t_s[np.argmax(pwm > 1e-9)] - 1)  # last second at 0
    full = float(t_s[np.argmax(pwm >= 1.0 - 1e-9)])
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.8))
    ax.plot(t_s, pwm, label="heat index PWM")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("heat index PWM (-)")
    ax2 = ax.twinx()
    ax2.plot(t_s, tmax, color="tab:red", ls="--", label="available torque")
    ax2.set_ylabel("available torque T_max (N·m)")
    ax.axvline(30, color="grey", lw=0.8)
    ax.axvline(130, color="grey", lw=0.8)
    ax.set_title("Fig. 4 analog: heat index at 2× continuous torque from cold")
    fig.legend(loc="center right", bbox_to_anchor=(0.85, 0.5))
    fig.tight_layout()
    save_png(fig, out_dir / "fig4_heat_index.png")
    plt.close(fig)
    return {"pwm_leaves_zero_s": leave, "pwm_reaches_one_s": full, "paper_leaves_zero_s": 30.0,
            "paper_reaches_one_s": 130.0, "torque_at_saturation_nm": float(tmax[-1]), "continuous_torque_nm": cont}


def thermal_cutoff_figure(out_dir: Path) -> dict[str, Any]:
    """Coolant off, motor at peak power from 20 °C: time to the 70 °C cutoff vs m·c_p·ΔT / net heat flow."""
    cfg = paper_bus()
    th, mo = cfg.thermal.pack(), cfg.motor.pack()
    w = 3600 * RPM
    torque = mot.peak_torque_nm(mo, w)
    speed = 60 / 3.6
    temp, temps, nets = 20.0, [20.0], []
    while temp < cfg.thermal.cutoff_temp_c and len(temps) < 5000:
        heat = mot.total_loss_w(mo, torque, w, cfg.thermal.extra_loss_frac, thm.derate_frac(th, temp))
        q_air, q_rad, q_cool = thm.heat_flows_w(th, temp, 20.0, 20.0, 0.0, speed)
        nets.append(heat - q_air - q_rad - q_cool)
        temp = thm.temperature_step(th, temp, heat, 20.0, 20.0, 0.0, speed, 1.0)[0]
        temps.append(temp)
    t_sim = len(temps) - 1
    net = float(np.mean(nets))
    t_an = cfg.thermal.heat_capacity_j_per_k * (cfg.thermal.cutoff_temp_c - 20.0) / net
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.8))
    ax.plot(np.arange(len(temps)), temps, label="simulated (eq 7)")
    ax.plot([0, t_an], [20, cfg.thermal.cutoff_temp_c], ls="--", label=f"m·c_p·ΔT / mean net heat = {t_an:.0f} s")
    ax.axhline(cfg.thermal.cutoff_temp_c, color="tab:red", lw=0.8, label="70 °C cutoff")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("motor temperature (°C)")
    ax.set_title("Motor at peak power (90 kW), coolant off, from 20 °C")
    ax.legend()
    fig.tight_layout()
    save_png(fig, out_dir / "thermal_time_to_cutoff.png")
    plt.close(fig)
    return {"time_to_cutoff_simulated_s": float(t_sim), "time_to_cutoff_analytic_s": float(t_an),
            "mean_net_heat_w": net, "heat_capacity_j_per_k": cfg.thermal.heat_capacity_j_per_k}


def table2_and_traces(out_dir: Path, cycles: tuple[str, ...]) -> dict[str, Any]:
    """Table 2 analog (rule strategy, fuel with and without the thermal model) and Figs. 7-10 analogs."""
    plt = pyplot()
    result: dict[str, Any] = {}
    for cycle in cycles:
        row = {}
        traces = {}
        for label, thermal in (("without_thermal", False), ("with_thermal", True)):
            cfg = paper_bus().with_thermal(thermal)
            res = run_strategy(get_strategy("rule"), cycle, "paper", config=cfg)
            row[label] = {k: res.summary[k] for k in ("fuel_l_per_100km", "fuel_corrected_l_per_100km",
                                                      "max_motor_temp_c", "heat_index_max", "soc_final")}
            traces[label] = res.trace
        row["paper_l_per_100km"] = PAPER_TABLE2.get(cycle)
        tr = traces["with_thermal"]
        t = np.arange(1, len(tr["motor_temp_c"]) + 1)
        pwm = np.asarray(tr["heat_index"])
        row["heat_index_first_rise_s"] = float(t[np.argmax(pwm > 0)]) if (pwm > 0).any() else None
        row["temp_final_mean_last_100s_c"] = float(np.mean(tr["motor_temp_c"][-100:]))
        fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
        axes[0].plot(t, tr["motor_temp_c"], label="thermal model on")
        axes[0].plot(t, traces["without_thermal"]["motor_temp_c"], alpha=0.6, label="thermal model off")
        axes[0].set_ylabel("motor temperature (°C)")
        axes[0].legend()
        axes[1].plot(t, pwm, color="tab:orange", label="heat index PWM")
        axes[1].set_ylabel("heat index PWM (-)")
        axes[1].set_xlabel("time (s)")
        axes[1].set_ylim(-0.02, 1.02)
        axes[1].legend()
        fig.suptitle(f"Motor temperature and heat index along {cycle} (rule strategy, paper scenario)")
        fig.tight_layout()
        save_png(fig, out_dir / f"fig_temperature_heat_index_{cycle}.png")
        plt.close(fig)
        result[cycle] = row
    return result


def _table3_md(t3: dict) -> str:
    lines = ["| figure | paper: off / 30 °C / 50 °C | ours: off | ours: 30 °C | ours: 50 °C | tolerance (off) |",
             "|---|---|---|---|---|---|"]
    names = {"top_speed_kmh": "top speed (km/h)", "accel_0_60_s": "0-60 km/h (s)",
             "grade_4pct_speed_kmh": "4 % grade speed (km/h)"}
    for k, name in names.items():
        p = " / ".join(f"{x:g}" for x in PAPER_TABLE3[k])
        ok = "met" if t3["within_tolerance"][k] else "MISSED"
        lines.append(f"| {name} | {p} | {t3['thermal_off'][k]:.2f} | {t3['thermal_30c'][k]:.2f} | "
                     f"{t3['thermal_50c'][k]:.2f} | ±{TABLE3_TOLERANCE[k]:.0%}: {ok} |")
    return "\n".join(lines)


def build_report(out_dir: str | Path, *, cycles: tuple[str, ...] = ("hwfet", "udds", "beijing"),
                 quick: bool = False) -> dict[str, Any]:
    """Compute every section, write the figures, ``paper.json`` and ``report.md``; return the numbers."""
    out = check_writable_dir(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    data: dict[str, Any] = {
        "table3": table3(resolution_kmh=0.5 if quick else 0.05, accel_dt_s=0.2 if quick else 0.1),
        "fig4": fig4(out),
        "thermal_cutoff": thermal_cutoff_figure(out),
        "table2": table2_and_traces(out, cycles),
    }
    data["wall_s"] = time.perf_counter() - t0
    atomic_write_json(out / "paper.json", data)
    atomic_write_text(out / "report.md", "\n".join(_performance_md(data) + _cycles_md(data["table2"])) + "\n")
    return data


def _performance_md(data: dict[str, Any]) -> list[str]:
    """The report's opening and its vehicle sections: Table 3, Fig. 4 and the time to the cutoff."""
    t3, f4, tc = data["table3"], data["fig4"], data["thermal_cutoff"]
    return ["# Paper reproduction report", "",
           "Our `paper_bus` beside the source paper (*Study on the Influence for Hybrid Electric Vehicle "
           "Performance by the Thermal Effects of Traction Motor*). The bus is our documented vehicle "
           "(docs/parameters.md), not the paper's unpublished one, so shapes are compared, and numbers "
           "where the paper gives them.", "",
           "## Table 3 analog: vehicle performance (coolant closed)", "", _table3_md(t3), "",
           "Top speed and grade speed are sustained (engine-alone) speeds, hence equal with and without the "
           "thermal model, as in the paper. The 0-60 km/h time grows with the starting temperature, as in the "
           "paper, but less: at a 30 °C start our heat index, which starts at −PWM_initial(30 °C) = −0.24 and "
           "rises at T_gain(T)/T_s per unit of overload, has not left zero within the 16 s run, so only the "
           "50 °C start (PWM_initial 0.12) derates the motor before 60 km/h. The paper leaves eq 10 (T_gain as "
           "a function of temperature) unspecified; ours is documented in `physics/thermal.py`.", "",
           "## Fig. 4 analog: heat index at twice the continuous torque", "",
           f"PWM leaves 0 at {f4['pwm_leaves_zero_s']:.0f} s (paper 30 s) and reaches 1 at "
           f"{f4['pwm_reaches_one_s']:.0f} s (paper 130 s); the available torque then equals the continuous "
           f"torque ({f4['torque_at_saturation_nm']:.1f} N·m). Same as the paper: eq 9 with the paper's "
           "constants.", "", "![Fig. 4 analog](fig4_heat_index.png)", "",
           "## Motor at peak power without coolant: time to the 70 °C cutoff", "",
           f"Simulated {tc['time_to_cutoff_simulated_s']:.0f} s; m·c_p·ΔT / mean net heat flow = "
           f"{tc['heat_capacity_j_per_k']:.0f} J/K × 50 K / {tc['mean_net_heat_w']:.0f} W = "
           f"{tc['time_to_cutoff_analytic_s']:.0f} s. (The paper gives no such figure; this checks eq 7.)", "",
           "![time to cutoff](thermal_time_to_cutoff.png)", ""]


def _cycles_md(t2: dict[str, Any]) -> list[str]:
    """The report's cycle sections: Table 2 and the Figs. 7-10 analogs."""
    md = ["## Table 2 analog: fuel with and without the thermal model (rule strategy)", "",
          "| cycle | paper without / with (L/100 km) | ours without | ours with | ours corrected without / with |",
          "|---|---|---|---|---|"]
    for cyc, row in t2.items():
        p = row["paper_l_per_100km"]
        ps = f"{p[0]:g} / {p[1]:g}" if p else "-"
        md.append(f"| {cyc} | {ps} | {row['without_thermal']['fuel_l_per_100km']:.3f} | "
                  f"{row['with_thermal']['fuel_l_per_100km']:.3f} | "
                  f"{row['without_thermal']['fuel_corrected_l_per_100km']:.3f} / "
                  f"{row['with_thermal']['fuel_corrected_l_per_100km']:.3f} |")
    deltas = {c: r["with_thermal"]["fuel_corrected_l_per_100km"] - r["without_thermal"]["fuel_corrected_l_per_100km"]
              for c, r in t2.items()}
    change = ", ".join(f"{c} {d:+.3f}" for c, d in deltas.items())
    md += ["", "The paper's Table 2 labels its highway row \"UDDS\" while its text says HWFET; we report both "
           "cycles. The paper's shape: fuel rises slightly with the thermal model on the highway cycle "
           "(+0.3 L/100 km) and is unchanged on the city-bus cycle. Ours, corrected fuel with minus without "
           f"the thermal model: {change} L/100 km. In our model the coolant holds the motor at the 35 °C "
           "thermostat, where the efficiency derate only begins, and the rule strategy's assist rarely builds "
           "the heat index, so the thermal model costs almost nothing in the paper's conditions: the "
           "city-bus result matches the paper, the highway rise does not appear. Our `beijing` is a synthetic "
           "cycle (no measured Beijing bus cycle is public), and our bus and its fuel map are not the paper's, "
           "so absolute L/100 km differ.",
           "", "## Figs. 7-10 analogs: temperature and heat index along the cycles", ""]
    for cyc, row in t2.items():
        rise = row["heat_index_first_rise_s"]
        md.append(f"**{cyc}**: peak temperature {row['with_thermal']['max_motor_temp_c']:.1f} °C, mean over the "
                  f"last 100 s {row['temp_final_mean_last_100s_c']:.1f} °C, heat index peak "
                  f"{row['with_thermal']['heat_index_max']:.2f}"
                  + (f", first above 0 at {rise:.0f} s." if rise is not None else ", never above 0."))
        md += ["", f"![{cyc}](fig_temperature_heat_index_{cyc}.png)", ""]
    md += ["Paper: on HWFET the heat index rises from ≈387 s to a peak ≈0.35 and the temperature peaks at "
           "≈44 °C, settling ≈37.5 °C; on Beijing the temperature hovers at 35 °C and the heat index stays 0. "
           "Ours: the Beijing shape is reproduced (temperature at the thermostat, heat index 0). On HWFET it is "
           "not: the 3000 W/(m²·K) coolant with a perfect radiator pins the motor at the 35 °C thermostat "
           "(losses of a few kW need only a few kelvin above the coolant), so there is no 44 °C peak; and the "
           "rule strategy's assist on our bus exceeds the continuous torque only in short bursts, which the "
           "heat index, starting at −PWM_initial = −0.3 and integrating at T_gain(35 °C)/T_s = 0.1/30 per "
           "unit of overload, absorbs without leaving 0. Sustained overload, as in UDDS's long climb to "
           "90 km/h, hot starts or the `hot` scenario, does build it (see the benchmark's hot rows). The "
           "paper's Figs. 7-8 are captioned UDDS although its text says HWFET; on UDDS our heat index "
           "builds between ≈390 and ≈580 s (the paper's curve rises from 387 s), to a lower peak.", ""]
    return md
