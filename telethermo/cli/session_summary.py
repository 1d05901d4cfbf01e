"""The figures of a session (``summary.json`` of ``telethermo session``) as the table it prints:
transparency per touch, oscillation, the material cue, rendering, tracking, discrimination, safety."""

from __future__ import annotations

import math

TRANSPARENCY_HEADER = [
    "touch",
    "object",
    "t_on s",
    "pre °C",
    "early 0-1 s °C",
    "0.1-1 s °C",
    "late °C",
    "window °C",
    "cue J",
    "direct cue J",
    "skin 1 s °C",
    "direct 1 s °C",
]
#: the per-touch keys of the transparency figures, in the order of :data:`TRANSPARENCY_HEADER` after the
#: touch number and the object
TRANSPARENCY_KEYS = (
    "t_on_s",
    "pre_C",
    "early_C",
    "early01_C",
    "late_C",
    "window_C",
    "cue_J",
    "direct_cue_J",
    "dskin_C",
    "direct_dskin_C",
)


def print_summary(fig: dict) -> None:
    """The figures as a table (telepresence: transparency per touch, tracking, discrimination, safety)."""
    run = fig.get("run", {})
    print(
        f"session {fig.get('scene')}: {fig.get('n_steps')} cycles "
        f"({fig.get('duration_s', 0):.2f} s of scene time) "
        f"in {run.get('wall_time_s', 0):.1f} s wall, start-up included"
    )
    res = run.get("master") or {}
    if res.get("cycles_per_s"):
        print(
            f"SYNC producer ({res['timing']}): {res['cycles_per_s']:,.0f} cycles/s, "
            f"{res['late_cycles']} late, "
            f"{res['lockstep_timeouts']} lockstep timeouts, "
            f"SYNC->TPDO p50 {_f(res.get('sync_to_tpdo_ms_p50'), ' ms')}"
            f" p99 {_f(res.get('sync_to_tpdo_ms_p99'), ' ms')}"
        )
    if fig.get("transparency"):
        _print_transparency(fig["transparency"])
    if fig.get("oscillation"):
        _print_oscillation(fig["oscillation"])
    cue = fig.get("discrimination_cue")
    if cue and cue.get("n_materials_compared", 2) < 2:
        print(f"material cue (heat drawn in the first second): n/a ({_touched(cue)})")
    elif cue:
        print(
            f"material cue (heat drawn in the first second): cue order (ours) kept the direct-touch order "
            f"{' > '.join(cue['direct_order_most_heat_first'])}: {_yes(cue['order_kept'])}, "
            f"smallest contrast ratio {_f(cue['contrast_ratio_min'])}"
        )
    if fig.get("render"):
        _print_render(fig["render"])
    trk = fig.get("tracking")
    if trk:
        print(
            f"tracking RMS in steady contact (internal: each controller vs its own estimate): master "
            f"{_f(trk.get('master_rms_C'), ' °C')}, slave {_f(trk.get('slave_rms_C'), ' °C')}"
        )
    if fig.get("discrimination"):
        _print_discrimination(fig["discrimination"])
    sfy = fig.get("safety", {})
    if sfy:
        print(f"safety: {sfy.get('n_trips', 0)} trips; time cut {sfy.get('time_cut_s')}")


def _print_transparency(tr: dict) -> None:
    rows = [list(TRANSPARENCY_HEADER)]
    for i, p in enumerate(tr["per_touch"], 1):
        rows.append([str(i), p["object"], *(_f(p[k]) for k in TRANSPARENCY_KEYS)])
    _table(rows)
    print(
        f"transparency (|skin - direct-touch skin|): headline {_f(tr['headline_error_C'], ' °C')} over "
        f"t_on-0.5..t_on+1 s; pre-contact {_f(tr['pre_contact_mean_error_C'], ' °C')}, early "
        f"{_f(tr['early_mean_error_C'], ' °C')}, late {_f(tr['late_mean_error_C'], ' °C')}"
    )


def _print_oscillation(osc: dict) -> None:
    verdict = "OSCILLATING" if osc["oscillating"] else "no oscillation"
    print(
        f"oscillation in settled contact ({osc['band_Hz'][0]:g}-{osc['band_Hz'][1]:g} Hz): {verdict}: worst "
        f"skin/direct-touch ratio {_f(osc['worst_ratio'])} (limit {osc['limit']:g}), skin "
        f"{_f(osc['skin_band_rms_max_C'], ' °C')} RMS, current {_f(osc['current_band_rms_max_A'], ' A')} RMS"
    )


def _print_render(rnd: dict) -> None:
    rows = [["touch", "material", "beta", "T_contact eq.1 °C", "rendered early °C", "error °C"]]
    for i, p in enumerate(rnd["per_touch"], 1):
        rows.append(
            [
                str(i),
                str(p["material"]),
                _f(p.get("beta")),
                _f(p["T_contact_eq1_C"]),
                _f(p["rendered_early_mean_C"]),
                _f(p["early_mean_error_C"]),
            ]
        )
    _table(rows)
    print(f"render: largest |mean error| {_f(rnd.get('max_abs_mean_error_C'), ' °C')}")


def _touched(d: dict) -> str:
    """Why an order across materials is not judged: fewer than two were touched within the session."""
    n = d.get("n_materials_compared", 0)
    return f"{n} material{'' if n == 1 else 's'} touched within the session: no order to keep"


def _print_discrimination(d: dict) -> None:
    if d.get("n_materials_compared", 2) < 2:
        print(f"rendered early temperature per material: n/a ({_touched(d)})")
        return
    print(
        f"rendered early temperature per material (0.1-1 s, mean over its touches; follows the finger's "
        f"history): rendered order {' < '.join(d['rendered_order_coldest_first'])} kept the direct-touch "
        f"temperature order {' < '.join(d['reference_order_coldest_first'])} with margins > 0: "
        f"{_yes(d['order_kept'])}, min margin {_f(d['min_margin_C'], ' °C')} "
        f"(threshold {d['threshold_C']} °C)"
    )


def _f(x, unit: str = "") -> str:
    """A figure to 3 decimals with its unit, or n/a."""
    return "n/a" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.3f}{unit}"


def _yes(flag) -> str:
    return "yes" if flag else "no"


def _table(rows: list[list[str]]) -> None:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for j, r in enumerate(rows):
        print("  ".join(c.rjust(w) for c, w in zip(r, widths)))
        if j == 0:
            print("  ".join("-" * w for w in widths))
