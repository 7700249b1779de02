"""Numeric codes for the two categorical values of the reset info: the episode's cycle and coolant mode.

RL libraries read every info value as a number (torchrl turns each entry into a tensor; a string
breaks it), so the info carries codes, and these functions turn them back into names:

* ``info["cycle_id"]`` → :func:`cycle_name`. The built-in cycles have fixed ids, their order in
  :func:`hev_thermal_env.cycles.list_cycles` (``hwfet`` 0 to ``beijing`` 4); any other cycle gets
  the next free id the first time the process meets its name, so its id is valid in the process
  that ran the env (whose ``env.unwrapped.cycle.name``, or ``envs.cycles[i].name``, is the name).
* ``info["coolant_code"]`` → :func:`coolant_mode`: the index in
  :data:`~hev_thermal_env.physics.config.COOLANT_MODES` (``"on"`` 0, ``"degraded"`` 1, ``"off"`` 2).

>>> from hev_thermal_env.envs import cycle_name, coolant_mode
>>> cycle_name(0), coolant_mode(2)
('hwfet', 'off')
"""

from __future__ import annotations

from ..cycles import list_cycles
from ..physics.config import COOLANT_MODES

_CYCLE_NAMES: list[str] = list(list_cycles())
_CYCLE_IDS: dict[str, int] = {name: i for i, name in enumerate(_CYCLE_NAMES)}


def cycle_id(name: str) -> int:
    """The id of the cycle called ``name`` (a new one, from the next free number, for a name not seen yet)."""
    code = _CYCLE_IDS.get(name)
    if code is None:
        code = _CYCLE_IDS[name] = len(_CYCLE_NAMES)
        _CYCLE_NAMES.append(name)
    return code


def cycle_name(code: int) -> str:
    """The name of the cycle with id ``code`` (``info["cycle_id"]`` of a reset)."""
    i = int(code)
    if not 0 <= i < len(_CYCLE_NAMES):
        raise KeyError(f"cycle id {code!r} is not known in this process (ids 0-{len(_CYCLE_NAMES) - 1}); "
                       "ids of cycles other than the built-in ones are given by the process that runs the env: "
                       "read env.unwrapped.cycle.name there")
    return _CYCLE_NAMES[i]


def coolant_code(mode: str) -> int:
    """The code of a coolant mode (``"on"`` 0, ``"degraded"`` 1, ``"off"`` 2)."""
    return COOLANT_MODES.index(mode)


def coolant_mode(code: int) -> str:
    """The coolant mode of ``info["coolant_code"]``."""
    i = int(code)
    if not 0 <= i < len(COOLANT_MODES):
        raise KeyError(f"coolant code {code!r}: expected 0-{len(COOLANT_MODES) - 1} ({', '.join(COOLANT_MODES)})")
    return COOLANT_MODES[i]
