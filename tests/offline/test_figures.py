"""Figures computed from a recording with known errors, and the CSV format round trip."""

import math
import os
import stat

import numpy as np
import pytest

from telethermo.atomic import write_text_atomic
from telethermo.cli.session_summary import print_summary
from telethermo.offline import compute_figures
from telethermo.recording import RecordingBuilder, RecordingError, read_recording_csv, write_recording_csv
from telethermo.offline.transparency import transparency_figures

DT = 0.01
CONTACTS = [
    dict(t_on_s=1.0, t_off_s=4.0, object="aluminium"),
    dict(t_on_s=5.0, t_off_s=8.0, object="steel"),
    dict(t_on_s=9.0, t_off_s=12.0, object="wood"),
]
REF = {"aluminium": 25.6, "steel": 26.9, "wood": 30.1}


def make(offset_early=0.2, offset_late=0.05, rendered_shift=None, t_end_s=13.0):
    b = RecordingBuilder({"scene": "synthetic", "period_s": DT, "mode": "telepresence", "contacts": CONTACTS})
    t_all = np.round(np.arange(0, t_end_s, DT), 10)
    for k, t in enumerate(t_all):
        ref, q_ref, touching, surf = 33.0, 0.0, 0, 33.0
        lim, trips = "", ""
        for c in CONTACTS:
            if c["t_on_s"] <= t <= c["t_off_s"]:
                touching = 1
                ref = REF[c["object"]]
                q_ref = -2.0
                dtc = t - c["t_on_s"]
                off = offset_early if dtc < 1.0 else offset_late
                if rendered_shift:
                    off += rendered_shift.get(c["object"], 0.0)
                surf = ref + off
        if k < 50:
            lim = "ramp|current_limit"
        if k == 700:
            trips = "peer_invalid"
        b.add(
            {
                "t_s": t,
                "m_true_surface_C": surf,
                "ref_T_contact_C": ref,
                "ref_Q_into_finger_W": q_ref,
                "m_true_Q_W": q_ref + 0.1,
                "m_true_Q_into_body_W": q_ref + 0.1,
                "ref_touching": touching,
                "m_target_C": 30.0 + 0.1 * math.sin(7 * t),
                "m_feedback_C": 30.0,
                "s_target_C": 30.0,
                "s_feedback_C": 30.0,
                "m_limits": lim,
                "m_new_trips": trips,
                "m_safety_state": 3 if 700 <= k < 720 else 0,
                "s_safety_state": 0,
            }
        )
    return b.build()


def test_transparency_errors_per_phase():
    f = compute_figures(make())
    tr = f["transparency"]
    assert tr["early_mean_error_C"] == pytest.approx(0.2, abs=1e-9)  # 0-1 s
    assert tr["early01_mean_error_C"] == pytest.approx(0.2, abs=1e-9)  # 0.1-1 s
    assert tr["late_mean_error_C"] == pytest.approx(0.05, abs=1e-9)
    assert tr["pre_contact_mean_error_C"] == pytest.approx(0.0, abs=1e-9)
    # the window [t_on - 0.5 s, t_on + 1 s): 50 samples at 0, 100 at 0.2 °C
    assert tr["headline_error_C"] == pytest.approx(0.2 * 100 / 150, abs=1e-9)
    assert tr["early01_max_error_C"] == pytest.approx(0.2, abs=1e-9)
    assert tr["early01_mean_flux_error_W"] == pytest.approx(0.1, abs=1e-9)
    assert len(tr["per_contact"]) == 3 and len(tr["per_touch"]) == 3
    # the cue: heat drawn from the finger over the first second, 100 samples of 10 ms
    for p in tr["per_touch"]:
        assert p["direct_cue_J"] == pytest.approx(2.0, abs=1e-9)
        assert p["cue_J"] == pytest.approx(1.9, abs=1e-9)
        assert p["direct_dskin_C"] == pytest.approx(REF[p["object"]] - 33.0, abs=1e-9)


def test_a_null_display_scores_its_closed_form():
    """A display that ignores the probe and holds the skin at T: its headline is mean |T - direct skin| over
    each touch's window, computed here directly from the reference."""
    rec = make()
    t, ref = rec.col("t_s"), rec.col("ref_T_contact_C")
    for T in (25.5, 33.0):
        skin = np.full_like(t, T)
        f = transparency_figures(t, skin, ref, np.zeros_like(t), rec.col("ref_Q_into_finger_W"), CONTACTS)
        expect = []
        for c in CONTACTS:
            w = (t >= c["t_on_s"] - 0.5 - 1e-9) & (t < c["t_on_s"] + 1.0 - 1e-9)
            expect.append(np.mean(np.abs(T - ref[w])))
        assert f["headline_error_C"] == pytest.approx(np.mean(expect), abs=1e-12)
        # a pad that draws nothing conveys no cue: the cue order cannot be kept
        assert all(p["cue_J"] == 0.0 for p in f["per_touch"]) and not f["cue"]["order_kept"]
    # holding the finger's temperature before the touches scores 0 before and the full drop after
    f = transparency_figures(
        t, np.full_like(t, 33.0), ref, np.zeros_like(t), rec.col("ref_Q_into_finger_W"), CONTACTS
    )
    for p in f["per_touch"]:
        assert p["pre_C"] == 0.0 and p["early_C"] == pytest.approx(33.0 - REF[p["object"]], abs=1e-9)


def test_tracking_rms_in_steady_contact():
    f = compute_figures(make())
    # master error 0.1·sin over steady windows ~ 0.1/sqrt(2); slave 0 -> pooled 0.05
    assert f["tracking"]["master_rms_C"] == pytest.approx(0.1 / math.sqrt(2), rel=0.05)
    assert f["tracking"]["slave_rms_C"] == 0.0
    assert f["tracking"]["rms_C"] == pytest.approx(0.05, rel=0.05)


def test_discrimination_order_and_margins():
    f = compute_figures(make())
    d = f["discrimination"]
    assert d["reference_order_coldest_first"] == ["aluminium", "steel", "wood"]
    assert d["order_kept"] and d["margins_above_threshold"]
    assert d["min_margin_C"] == pytest.approx(26.9 - 25.6, abs=0.01)
    # steel rendered 1.0 °C too cold: order still kept but margin below 0.7 °C
    d2 = compute_figures(make(rendered_shift={"steel": -1.0}))["discrimination"]
    assert d2["order_kept"] and not d2["margins_above_threshold"]
    d3 = compute_figures(make(rendered_shift={"steel": -1.5}))["discrimination"]
    assert not d3["order_kept"]


def test_a_session_ended_early_judges_only_the_touches_it_reached(capsys):
    # `telethermo session --duration 3`: the steel and wood touches never happen. They had a skin change of
    # 0.000 °C and an order "aluminium < steel < wood" judged over one material; now n/a, no order
    f = compute_figures(make(t_end_s=3.0))
    per = f["transparency"]["per_touch"]
    assert math.isfinite(per[0]["dskin_C"]) and per[0]["dskin_C"] == pytest.approx(
        REF["aluminium"] + 0.05 - 33.0, abs=1e-9
    )
    assert all(p["dskin_C"] is None and p["cue_J"] is None for p in per[1:])  # NaN, as JSON null
    assert (
        f["discrimination_cue"]["n_materials_compared"] == 1
        and not f["discrimination_cue"]["order_kept"]
        and not f["discrimination_cue"]["pairs"]
    )
    d = f["discrimination"]
    assert (
        d["n_materials_compared"] == 1
        and not d["order_kept"]
        and d["reference_order_coldest_first"] == ["aluminium"]
    )
    print_summary(f)
    out = capsys.readouterr().out
    assert out.count("n/a (1 material touched within the session: no order to keep)") == 2, out
    assert "steel < wood" not in out
    # the full session still compares all three
    assert compute_figures(make())["discrimination_cue"]["n_materials_compared"] == 3


def test_safety_time_at_limits_and_trips():
    s = compute_figures(make())["safety"]
    assert s["time_at_limit_s"]["master"] == {"current_limit": pytest.approx(0.5), "ramp": pytest.approx(0.5)}
    assert s["time_cut_s"]["master"] == pytest.approx(0.2)
    assert s["trips"] == [{"t_s": 7.0, "side": "master", "trip": "peer_invalid", "emcy_code": "0xFF02"}]


def test_csv_round_trip_gives_the_same_figures(tmp_path):
    rec = make()
    p = write_recording_csv(tmp_path / "r.csv", rec)
    back = read_recording_csv(p)
    assert back.meta == rec.meta
    for c in rec.columns:
        if isinstance(rec.columns[c], list):
            assert back.columns[c] == rec.columns[c]
        else:
            np.testing.assert_array_equal(back.columns[c], rec.columns[c])
    assert compute_figures(back) == compute_figures(rec)


def test_bad_csv_names_file_line_and_column(tmp_path):
    p = write_recording_csv(tmp_path / "r.csv", make())
    lines = p.read_text().split("\n")
    header = lines[2].split(",")
    row = lines[5].split(",")
    row[header.index("m_Q_W")] = "abc"
    lines[5] = ",".join(row)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines))
    with pytest.raises(
        RecordingError, match=r"bad\.csv: line 6: column 'm_Q_W': expected a number, got 'abc'"
    ):
        read_recording_csv(bad)
    (tmp_path / "x.csv").write_text("t_s\n1\n")
    with pytest.raises(RecordingError, match=r"x\.csv: line 1: expected '# telethermo-recording 1'"):
        read_recording_csv(tmp_path / "x.csv")


def test_plot_is_a_png(tmp_path):
    from telethermo.offline.plot import write_session_png

    p = write_session_png(tmp_path / "s.png", make())
    assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 10_000


def test_atomic_writes_get_the_usual_file_mode(tmp_path):
    old = os.umask(0o022)
    try:
        p = write_text_atomic(tmp_path / "a.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(p.stat().st_mode) == 0o644 and p.read_text() == "x"
