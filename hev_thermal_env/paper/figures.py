"""The paper's Table 3 (top speed, 0-60 km/h, 4 % grade speed), which ``evaluate.py performance`` prints beside ours.

Every figure of the paper with its tolerance, these among them, is one table in the workshop of a checkout,
``tools/paper/figures.py`` (docs/paper.md).
"""

from __future__ import annotations

#: The runs of Table 3 (coolant closed): thermal model off, and on from a 30 or 50 °C start.
TABLE3_RUNS = ("off", "30c", "50c")
#: Table 3 with the thermal model off: top speed and speed on a 4 % grade (km/h; the same with it on), 0-60 km/h (s).
TABLE3_OFF = {"top_speed_kmh": 89.0, "accel_0_60_s": 16.4, "grade_4pct_speed_kmh": 48.3}
#: Table 3's 0-60 km/h time from a 30 or 50 °C start less that with the thermal model off (s).
TABLE3_ACCEL_RISE_S = {"30c": 0.4, "50c": 0.7}


def table3_paper(run: str) -> dict[str, float]:
    """The paper's Table 3 row of ``run`` (one of :data:`TABLE3_RUNS`): top speed, 0-60 km/h, 4 % grade speed."""
    off = TABLE3_OFF["accel_0_60_s"]
    accel = off if run == "off" else round(off + TABLE3_ACCEL_RISE_S[run], 6)
    return {**TABLE3_OFF, "accel_0_60_s": accel}
