"""The packed parameter layout is derived from the dataclass fields, so it cannot silently swap parameters."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hev_thermal_env.physics import battery, config, driveline, engine, glider, motor, thermal
from hev_thermal_env.physics.params import Layout, Params, Slot, spec

LAYOUTS = {
    "glider": glider.LAYOUT, "driveline": driveline.LAYOUT, "engine": engine.LAYOUT, "motor": motor.LAYOUT,
    "thermal": thermal.LAYOUT, "battery": battery.LAYOUT, "powertrain": config.POWERTRAIN_LAYOUT,
}


@pytest.mark.parametrize("component", sorted(LAYOUTS))
def test_each_scalar_field_moves_only_its_own_slot(component):
    """Perturb one field at a time: exactly the slot named after it (or converted from it) changes."""
    layout = LAYOUTS[component]
    params = getattr(config.paper_bus(), component)
    base = params.pack()
    assert base.size == layout.size
    for slot in layout.slots:
        if slot.size != 1 or len(slot.packs()) != 1:
            continue
        name = slot.packs()[0]
        value = getattr(params, name)
        if isinstance(value, bool):
            changed = params.replace(**{name: not value})
        elif isinstance(value, (int, float)):
            try:
                changed = params.replace(**{name: type(value)(value * 1.001 + (1 if isinstance(value, int) else 0))})
            except ValueError:
                changed = params.replace(**{name: type(value)(value * 0.999)})
        else:
            continue
        diff = np.flatnonzero(changed.pack() != base)
        assert layout[slot.name] in diff, f"{component}.{name}: its slot did not change"
        for i in diff:  # a scalar field may feed derived slots, never another field's own slot
            owner = next(s for s in layout.slots if layout[s.name] <= i < layout[s.name] + s.size)
            assert owner is slot or owner.packs() == () or name in owner.packs(), \
                f"{component}.{name} changed slot {owner.name!r}"


def test_reordered_fields_keep_every_index_pointing_at_its_parameter():
    @dataclasses.dataclass(frozen=True)
    class AB(Params):
        a_w: float = spec(1.0, "a")
        b_w: float = spec(2.0, "b")

    @dataclasses.dataclass(frozen=True)
    class BA(Params):
        b_w: float = spec(2.0, "b")
        a_w: float = spec(1.0, "a")

    for cls in (AB, BA):
        layout = Layout.of_fields(cls)
        v = layout.pack(cls(a_w=10.0, b_w=20.0))
        assert v[layout["a_w"]] == 10.0 and v[layout["b_w"]] == 20.0


def test_a_field_in_no_slot_is_an_error():
    @dataclasses.dataclass(frozen=True)
    class Two(Params):
        a_w: float = spec(1.0, "a")
        b_w: float = spec(2.0, "b")

    with pytest.raises(ValueError, match=r"\['b_w'\]"):
        Layout(Two, [Slot("a_w")])
    with pytest.raises(ValueError, match="twice"):
        Layout(Two, [Slot("a_w"), Slot("b_w"), Slot("a_w")])


def test_tables_are_padded_and_too_long_tables_refused():
    lay = driveline.LAYOUT
    v = driveline.DrivelineParams(gear_ratios=(4.0, 2.0, 1.0)).pack()
    start = lay["gear_ratios"]
    assert v[lay["n_gears"]] == 3
    assert list(v[start:start + driveline.MAX_GEARS]) == [4.0, 2.0, 1.0] + [0.0] * (driveline.MAX_GEARS - 3)
    with pytest.raises(ValueError, match="holds"):
        Slot("x", 2).value(type("P", (), {"x": (1.0, 2.0, 3.0)})())
