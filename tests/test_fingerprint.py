"""A trained policy knows which physics it was trained on, and says so once when that changes."""

from __future__ import annotations

import logging
from pathlib import Path

from hev_thermal_env.agents.policy_files import load_policy, warn_if_other_physics
from hev_thermal_env.physics import paper_bus
from hev_thermal_env.physics.fingerprint import physics_fingerprint


def test_fingerprint_follows_the_numbers_not_the_object():
    bus = paper_bus()
    assert physics_fingerprint(bus) == physics_fingerprint(paper_bus()) == physics_fingerprint()
    lossier = bus.replace(motor=bus.motor.replace(copper_loss_coeff=bus.motor.copper_loss_coeff * 1.01))
    assert physics_fingerprint(lossier) != physics_fingerprint(bus)


def test_other_physics_gives_one_warning_line(caplog, tmp_path):
    stale = {"versions": {"physics_fingerprint": "0000000000000000"}}
    with caplog.at_level(logging.WARNING, logger="hev_thermal_env"):
        first = warn_if_other_physics(tmp_path / "model.zip", stale)
        again = warn_if_other_physics(tmp_path / "model.zip", stale)
    assert first == again and "retrain" in first and "\n" not in first
    assert [r.getMessage() for r in caplog.records] == [first]
    assert warn_if_other_physics(tmp_path / "model.zip", {"versions": {"physics_fingerprint": physics_fingerprint()}}) \
        is None
    assert "unrecorded" in warn_if_other_physics(tmp_path / "other.zip", {})


def test_the_shipped_policy_records_its_physics():
    policy = load_policy(Path(__file__).resolve().parents[1] / "agents" / "policies" / "ppo_default")
    assert policy.config["versions"]["physics_fingerprint"]
