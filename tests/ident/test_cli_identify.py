"""`telethermo identify`: experiment on a simulated rig, report, model file; user errors exit 2."""

import numpy as np

from telethermo.cli.main import main
from telethermo.ident import load_model


def test_identify_writes_a_valid_model_and_reports(tmp_path, capsys):
    out = tmp_path / "m.json"
    png = tmp_path / "fig.png"
    rc = main(
        [
            "identify",
            "--samples",
            "3000",
            "--validation",
            "1000",
            "--orders",
            "3,3,1,1",
            "--seed",
            "2",
            "--out",
            str(out),
            "--plot",
            str(png),
        ]
    )
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "(100.0 %)" in cap.err and "identify: experiment" in cap.err  # progress on stderr
    for words in (
        "held-out free run",
        "heat flux",
        "stability                 stable",
        "model written",
        "capacity (eq. 13)         14 steady states",
    ):
        assert words in cap.out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    tem = load_model(out, expect_period_s=0.01)
    assert tem.temperature.orders.as_dict() == {"n": 3, "m": 3, "p": 1, "q": 1}
    assert tem.meta["rig"] == "sim.free_pad_rig" and tem.meta["seed"] == 2
    assert tem.capacity is not None and tem.capacity.metrics["n_points"] == 14
    assert tem.temperature.metrics["heldout_free_run_max_C"] < 0.5
    worst = float(cap.out.split("held-out free run")[1].split("worst")[1].split("°C")[0])
    assert np.isclose(worst, tem.temperature.metrics["heldout_free_run_max_C"], atol=1e-4)


def test_identify_user_errors_exit_2_and_write_nothing(tmp_path, capsys):
    out = tmp_path / "m.json"
    assert main(["identify", "--orders", "3,3,3", "--out", str(out)]) == 2
    assert "--orders" in capsys.readouterr().err
    assert main(["identify", "--samples", "50", "--out", str(out)]) == 2
    assert main(["identify", "--scene", "finger_on_display", "--out", str(out)]) == 2
    assert "touches nothing" in capsys.readouterr().err
    assert main(["identify", "--scene", "no_such_scene", "--out", str(out)]) == 2
    assert not out.exists()
