"""``--set variants.V.observer.type=NEW`` alone: the replaced method's gains go, the new one starts from its
defaults, and the gains it has no default for are named in one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from ftc_mj import load_scenario
from ftc_mj.config.errors import InputError

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "puma_fault.yaml"


def test_a_new_type_with_its_gains_set_alongside_runs():
    scenario = load_scenario(SCENARIO, duration=0.01, overrides=[
        "variants.proposed.observer.type=tosmo", "variants.proposed.observer.gains.D=22"])
    assert scenario.written()["variants"]["proposed"]["observer"] == {"type": "tosmo", "gains": {"D": 22}}


def test_the_same_type_keeps_the_files_gains():
    before = load_scenario(SCENARIO, duration=0.01).written()["variants"]["proposed"]["observer"]["gains"]
    scenario = load_scenario(SCENARIO, duration=0.01, overrides=["variants.proposed.observer.type=hs_tosmo"])
    assert scenario.written()["variants"]["proposed"]["observer"]["gains"] == before


@pytest.mark.parametrize("method, first, also", [("kalman", "process_d", "; it also needs measurement"),
                                                 ("eso", "bandwidth", "")])
def test_a_new_type_alone_names_the_gains_it_needs(method, first, also):
    with pytest.raises(InputError) as error:
        load_scenario(SCENARIO, duration=0.01, overrides=[f"variants.proposed.observer.type={method}"])
    assert str(error.value) == (f"{SCENARIO}: variants.proposed.observer.gains.{first}: required field is missing "
                                f"(observer {method!r} has no default for it{also})")
