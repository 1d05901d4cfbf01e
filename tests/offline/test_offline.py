"""Offline sessions on the simulated rigs: guiatni §5.3 telepresence, yamamoto rendering, REAL32 path, files.

Figures are physics (truth of the simulator, direct-touch reference): air rendering before a touch, the
material cue's order, the envelope; the figures against the optimal-current bound and the null displays
are measured by bench/transparency_bench.py (docs/control.md), not asserted here.
"""

import json

import numpy as np
import pytest

from telethermo.control.rendering import load_render_table, pad_preset_temperature
from telethermo.offline import compute_figures, run_offline_session, write_session
from telethermo.recording import read_recording_csv

sim = pytest.importorskip("sim")


@pytest.fixture(scope="module")
def guiatni():
    return run_offline_session("probe_touches_al_steel_wood")


@pytest.fixture(scope="module")
def yamamoto():
    return run_offline_session("virtual_materials")


def test_guiatni_air_rendering_keeps_the_finger_natural(guiatni):
    """Before the first touch the probe is in air: the display renders air, so the operator's finger (which
    starts at its natural temperature, the scene's settled start) stays where the direct-touch finger is,
    and the pad draws from it only what air would (its natural loss, ~0.03 W)."""
    rec = guiatni.recording
    t = rec.col("t_s")
    pre = t < 1.0
    skin, ref = rec.col("m_true_surface_C")[pre], rec.col("ref_T_contact_C")[pre]
    assert np.max(np.abs(skin - ref)) <= 0.02
    q = rec.col("m_true_Q_into_body_W")[pre]  # > 0 heats the finger
    air_loss_W = 15.0 * 0.015 * 0.015 * (ref[0] - 25.0)  # h·A·(T_skin − T_air): what air would draw
    assert np.all(np.abs(q) <= 0.02 + air_loss_W)
    assert np.all(np.abs(q + air_loss_W) <= 0.02)


def test_guiatni_figures_are_the_honest_ones(guiatni):
    tr = guiatni.figures["transparency"]
    assert len(tr["per_touch"]) == 6 and len(tr["per_contact"]) == 6
    # the headline is the mean of the per-touch window errors; early (0-1 s) includes the first 0.1 s
    assert tr["headline_error_C"] == pytest.approx(
        np.mean([p["window_C"] for p in tr["per_touch"]]), abs=1e-12
    )
    for p in tr["per_touch"]:
        w = (0.5 * p["pre_C"] + 1.0 * p["early_C"]) / 1.5  # equal sample weights in the 1.5 s window
        assert p["window_C"] == pytest.approx(w, abs=0.01)
    assert guiatni.figures["tracking"]["internal"]


def test_guiatni_material_cue_order_kept(guiatni):
    """The cue (heat drawn from the finger in the first second) orders the materials as direct touch does:
    aluminium draws the most, wood the least; the display draws more from the finger on metal than on wood."""
    cue = guiatni.figures["discrimination_cue"]
    assert cue["direct_order_most_heat_first"] == ["aluminium", "steel", "wood"]
    assert cue["order_kept"]
    per = guiatni.figures["transparency"]["per_touch"]
    for p in per:
        assert p["cue_J"] > 0 and p["direct_cue_J"] > 0  # every touch draws heat from the finger
    wood = [p["cue_J"] for p in per if p["object"] == "wood"]
    metal = [p["cue_J"] for p in per if p["object"] != "wood"]
    assert max(wood) < min(metal)


def test_guiatni_safety_quiet(guiatni):
    rec = guiatni.recording
    s = guiatni.figures["safety"]
    assert s["n_trips"] == 0 and s["time_cut_s"] == {"master": 0.0, "slave": 0.0}
    for side in "ms":
        I = rec.col(f"{side}_current_A")
        assert np.all(np.abs(I) <= 0.8 * 3.0 + 1e-12)
        surf = rec.col(f"{side}_true_surface_C")
        surf = surf[np.isfinite(surf)]
        assert surf.min() >= 15.0 and surf.max() <= 43.0


@pytest.mark.parametrize("i,material", list(enumerate(["eps", "wood", "ceramic", "brass"])))
def test_yamamoto_render_within_0p2_of_eq1(yamamoto, i, material):
    pt = yamamoto.figures["render"]["per_touch"][i]
    assert pt["material"] == material
    beta = load_render_table()[material]
    assert pt["beta"] == beta
    # the pre-set is eq. 7 with Table 1's beta, the finger as measured before the touch
    assert pt["T_pad0_C"] == pytest.approx(
        pad_preset_temperature(pt["T_finger0_used_C"], 26.0, beta, 2.23), abs=1e-9
    )
    # rendered contact temperature (the skin, simulator truth), 0.1-1 s after contact, vs eq. 1 with the
    # skin's true temperature before the touch
    assert abs(pt["early_mean_error_C"]) <= 0.2
    assert pt["early_mean_abs_error_C"] <= 0.25


def test_yamamoto_order_of_materials(yamamoto):
    r = [p["rendered_early_mean_C"] for p in yamamoto.figures["render"]["per_touch"]]
    assert r[0] > r[1] > r[2] > r[3]  # EPS warmest ... brass coldest


def test_real32_path_equals_offline_path_up_to_rounding():
    a = run_offline_session("probe_touches_al_steel_wood", duration_s=8.0)
    b = run_offline_session("probe_touches_al_steel_wood", duration_s=8.0, rounding="real32")
    pe = b.recording.col("m_peer_estimate_C")[1:]
    assert np.array_equal(pe, pe.astype(np.float32).astype(float))
    assert not np.array_equal(a.recording.col("m_peer_estimate_C"), b.recording.col("m_peer_estimate_C"))
    # REAL32 keeps ~7 digits (~2e-6 °C at 30 °C); the bilateral loop amplifies it, but it stays
    # two orders of magnitude under the figures' scale (0.5 °C)
    for c, tol in (("m_true_surface_C", 0.01), ("s_estimate_C", 0.01), ("m_current_A", 0.02)):
        x, y = a.recording.col(c), b.recording.col(c)
        m = np.isfinite(x)
        assert np.max(np.abs(x[m] - y[m])) <= tol
    fa, fb = a.figures["transparency"], b.figures["transparency"]
    assert abs(fa["early_mean_error_C"] - fb["early_mean_error_C"]) <= 0.005
    assert abs(fa["headline_error_C"] - fb["headline_error_C"]) <= 0.005


def test_session_files_round_trip(tmp_path):
    res = run_offline_session("probe_touches_al_steel_wood", duration_s=6.0)
    paths = write_session(tmp_path / "out", res)
    summary = json.loads(paths["json"].read_text())
    assert summary == json.loads(json.dumps(res.figures))
    back = read_recording_csv(paths["csv"])
    assert compute_figures(back) == res.figures
    assert paths["png"].read_bytes()[:4] == b"\x89PNG"


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="rounding: expected one of"):
        run_offline_session("probe_touches_al_steel_wood", rounding="real64")
    with pytest.raises(ValueError, match="scene|<name>"):
        run_offline_session("no_such_scene")


def test_finger_on_display_is_held_at_neutral():
    """A virtual scene that renders nothing: the display regulates the skin at 32 °C through lift and
    re-touch, no trip."""
    res = run_offline_session("finger_on_display")
    f = res.figures
    assert f["mode"] == "hold" and f["hold"]["hold_C"] == 32.0 and f["safety"]["n_trips"] == 0
    rec = res.recording
    t, skin = rec.col("t_s"), rec.col("m_true_surface_C")
    for a, b in ((4.0, 9.9), (15.0, 19.9)):
        m = (t >= a) & (t < b)
        assert np.all(np.abs(skin[m] - 32.0) <= 0.1)
    assert np.all(np.isnan(skin[(t > 10.05) & (t < 11.95)]))  # lifted: nothing touches the pad
