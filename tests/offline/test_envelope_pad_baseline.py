"""The envelope's constant-pad baseline (telethermo.offline.envelope.hold_skin) is a pad its holder drives
well: a weak module held cold stops at its maximum-cooling current, I* = α·T_c/R, and never turns that
current into heat. Without that stop the matrix's condition 88 'held at 15 °C' ran the skin to 44.8 °C, a
baseline any controller beats."""

from __future__ import annotations

import numpy as np
import pytest

from telethermo.offline.envelope import SKIN_CLAMP_C, condition_scene, hold_skin
from telethermo.sim.tem import guiatni_capacities_W, load_rig_params
from tests.support.conditions import pinned_condition

#: the finger's core, °C: a pad that only cools cannot bring the skin above it
CORE_C = 37.0


def test_a_weak_module_held_cold_cools_at_its_best_and_never_heats_the_skin():
    c = pinned_condition("weak_display_warm_room")
    sc = condition_scene(c)[0]
    tem = sc.rig_params.tem
    i_star = tem.peak_cooling_current_A(SKIN_CLAMP_C[0])
    assert i_star < 0.2 * tem.I_max_A  # the module's cooling peaks far below its drive's limit
    skin = hold_skin(sc, SKIN_CLAMP_C[0])
    # measured 35.4 °C at most (the room is 30.5 °C, the finger perfused at 37 °C); 44.8 °C before the stop
    assert np.max(skin) < CORE_C, np.max(skin)
    # holding at the room's temperature asks for less cooling than the clamp: the skin is no colder there
    warm = hold_skin(sc, c.ambient_C)
    assert np.min(skin) <= np.min(warm) + 0.05, (np.min(skin), np.min(warm))


@pytest.mark.parametrize("T_cold_C", [15.0, 25.0, 43.0])
def test_the_stop_is_where_the_module_cools_most(T_cold_C):
    """guiatni eq. 5 (the simulator's steady cooling capacity, no temperature difference across the module):
    the cooling capacity peaks at the stop, within a 1 mA grid."""
    tem = load_rig_params().tem
    i_star = tem.peak_cooling_current_A(T_cold_C)
    grid = np.arange(0.001, 3.0 * i_star, 0.001)
    pc = [guiatni_capacities_W(tem, -i, T_cold_C, T_cold_C)[1] for i in grid]
    assert grid[int(np.argmax(pc))] == pytest.approx(i_star, abs=0.001)
