"""Energy balance: electrical input − heat out to reservoirs = change of stored heat, to 0.1 %."""

from __future__ import annotations

import numpy as np
import pytest

from telethermo import sim


def prbs(rng, n, hold=20, amp=1.5):
    return np.repeat(rng.choice([-amp, amp], size=n // hold + 1), hold)[:n]


@pytest.mark.parametrize("role", ["master", "slave"])
def test_energy_balance_over_the_probe_scene(role):
    scene = sim.load_scene("probe_touches_al_steel_wood")
    rig = sim.build_rig(scene, role, seed=0)
    rng = np.random.default_rng(1)
    currents = prbs(rng, 1500)
    p = rig.params.tem
    E_el_independent = 0.0

    def electrical_power(I):  # I·V with V = α·(T_p − T_s) + R·I (module terminals)
        Ts, Tp = rig.x[1], rig.x[2]
        return I * (p.alpha_V_K * (Tp - Ts) + p.R_ohm * I)

    for I in currents:  # 15 s: several make/break events on the slave
        rig.apply_current(I)
        P0 = electrical_power(I)
        rig.advance(0.01)
        E_el_independent += 0.5 * 0.01 * (P0 + electrical_power(I))
    bal = rig.energy_balance()
    scale = max(abs(bal["E_in_J"]), abs(bal["E_out_J"]), abs(bal["dE_stored_J"]))
    assert scale > 1.0  # a real exchange of heat happened
    assert abs(bal["residual_J"]) <= 1e-3 * scale
    # the electrical input the integrator booked equals ∫ I·V dt computed from the states, to 0.1 %
    assert bal["E_in_J"] == pytest.approx(E_el_independent, rel=1e-3)


def test_energy_balance_of_the_reference():
    """The direct-touch reference conserves energy too: finger + objects, heat out through core and air."""
    scene = sim.load_scene("probe_touches_al_steel_wood")
    ref = sim.build_reference(scene)
    for _ in range(1200):
        ref.advance(0.01)
        if ref.touching is None and ref.t_s > 5.0:
            mid = ref.energy_balance()  # also balanced between touches
            assert abs(mid["residual_J"]) <= 1e-3 * max(abs(mid["E_out_J"]), abs(mid["dE_stored_J"]))
    bal = ref.energy_balance()  # here (t = 12 s): while touching wood
    scale = max(abs(bal["E_out_J"]), abs(bal["dE_stored_J"]))
    assert ref.touching == "wood" and scale > 0.1
    assert abs(bal["residual_J"]) <= 1e-3 * scale
