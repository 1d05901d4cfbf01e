"""Issue 25: the demo summary said "order kept False" for one figure while the README speaks of another
"order kept": the two figures are named apart, and say yes/no."""

from __future__ import annotations

from telethermo.cli.session import print_summary


def test_the_two_order_figures_are_named_apart(capsys):
    fig = {
        "scene": "s",
        "n_steps": 10,
        "duration_s": 0.1,
        "discrimination_cue": {
            "direct_order_most_heat_first": ["aluminium", "steel", "wood"],
            "order_kept": True,
            "contrast_ratio_min": 1.5,
        },
        "discrimination": {
            "rendered_order_coldest_first": ["aluminium", "wood", "steel"],
            "reference_order_coldest_first": ["aluminium", "steel", "wood"],
            "order_kept": False,
            "min_margin_C": -0.2,
            "threshold_C": 0.5,
        },
    }
    print_summary(fig)
    out = capsys.readouterr().out.splitlines()
    assert (
        "material cue (heat drawn in the first second): cue order (ours) kept the direct-touch order "
        "aluminium > steel > wood: yes, smallest contrast ratio 1.500"
    ) in out
    assert (
        "rendered early temperature per material (0.1-1 s, mean over its touches; follows the finger's "
        "history): rendered order aluminium < wood < steel kept the direct-touch temperature order "
        "aluminium < steel < wood with margins > 0: no, min margin -0.200 °C (threshold 0.5 °C)"
    ) in out
    assert not any("False" in line or "True" in line for line in out)
