"""Stress cases of the control core (telethermo.control.core.step) on a simulated master rig with a finger.

The rig is the simulator's truth: "the pad" below is the top face of the flux sensor (what the finger
touches, ``RigTruth.T_contact_face_C``), which no controller sees. The envelope promises the setpoint in
[T_min_C, T_max_C] and |I| <= 0.8·I_max; the pad itself may lag the setpoint, so it is checked against
[T_min_C - PAD_TOL_C, T_max_C + PAD_TOL_C].
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from tests.stress.cases.case import Case
from telethermo.control import safety as sf
from telethermo.control.core import init_state, step
from telethermo.control.params import default_params
from telethermo.control.types import PeerValues, Role
from tests.stress.cases.sim import load_scene_doc
from telethermo import sim
from telethermo.offline.runner import run_offline_session

PERIOD_S = 0.01
PAD_TOL_C = 0.5


def master_rig(duration_s: float, seed: int = 0):
    """A master rig with the operator's finger on the pad for the whole run (noise on)."""
    doc = {
        "scene": {
            "name": "finger_hold",
            "kind": "telepresence",
            "duration_s": duration_s,
            "period_s": PERIOD_S,
            "ambient_C": 25.0,
        },
        "master": {"contacts": [{"start_s": 0.0, "end_s": duration_s + 1.0, "force_N": 8.0}]},
        "noise": {"seed": seed},
    }
    return sim.build_rig(load_scene_doc(doc, "finger_hold"), "master")


class Loop:
    """Master core + rig, stepped one SYNC at a time; tracks the invariants."""

    def __init__(self, duration_s: float, *, safety: sf.SafetyLimits | None = None, seed: int = 0) -> None:
        self.rig = master_rig(duration_s, seed)
        lim = safety or sf.SafetyLimits(I_max_A=self.rig.I_max_A)
        self.params = default_params(Role.MASTER, period_s=PERIOD_S, safety=lim)
        self.lim = lim
        s0 = self.rig.read()
        self.state = init_state(self.params, None, s0)
        self.max_abs_I = 0.0
        self.pad_min, self.pad_max = math.inf, -math.inf
        self.sp_min, self.sp_max = math.inf, -math.inf
        self.nonfinite = 0
        self.trips: set[str] = set()
        self.last = None

    def step(self, peer: PeerValues | None, *, advance: int = 1) -> None:
        s = self.rig.read()
        res = step(s, peer, self.params, self.state)
        self.state = res.state
        self.last = res
        I = res.current_A
        if not (math.isfinite(I) and math.isfinite(res.out.estimate_C) or not math.isfinite(s.T_sensor_C)):
            self.nonfinite += 1
        if math.isfinite(I):
            self.max_abs_I = max(self.max_abs_I, abs(I))
        else:
            self.max_abs_I = math.inf
        sp = res.status.setpoint_C
        self.sp_min, self.sp_max = min(self.sp_min, sp), max(self.sp_max, sp)
        self.trips |= {t.value for t in res.status.safety.new_trips}
        self.rig.apply_current(I)
        for _ in range(advance):
            self.rig.advance(PERIOD_S)
            pad = self.rig.truth().T_contact_face_C
            self.pad_min, self.pad_max = min(self.pad_min, pad), max(self.pad_max, pad)

    def check(self, c: Case, label: str) -> None:
        lim = self.lim
        c.fig(
            **{
                f"{label}_max_abs_current_A": self.max_abs_I,
                f"{label}_pad_min_C": self.pad_min,
                f"{label}_pad_max_C": self.pad_max,
                f"{label}_setpoint_range_C": (self.sp_min, self.sp_max),
                f"{label}_trips": sorted(self.trips),
            }
        )
        c.require(
            self.max_abs_I <= lim.I_limit_A + 1e-12,
            f"{label}: |I| max {self.max_abs_I:.4g} A <= {lim.I_limit_A:.4g} A",
        )
        c.require(
            lim.T_min_C <= self.sp_min and self.sp_max <= lim.T_max_C,
            f"{label}: setpoint [{self.sp_min:.3f}, {self.sp_max:.3f}] within [{lim.T_min_C}, {lim.T_max_C}]",
        )
        c.require(
            lim.T_min_C - PAD_TOL_C <= self.pad_min and self.pad_max <= lim.T_max_C + PAD_TOL_C,
            f"{label}: pad [{self.pad_min:.3f}, {self.pad_max:.3f}] °C within the envelope ± {PAD_TOL_C}",
        )
        c.require(
            self.nonfinite == 0, f"{label}: {self.nonfinite} steps with a non-finite current or estimate"
        )


BAD_PEERS: dict[str, tuple[PeerValues, bool]] = {
    # name -> (peer values, the envelope must trip PEER_INVALID/PEER_LOST)
    "nan_estimate": (PeerValues(math.nan, 0.0), True),
    "+inf_estimate": (PeerValues(math.inf, 0.0), True),
    "-inf_estimate": (PeerValues(-math.inf, 0.0), True),
    "1e30_estimate": (PeerValues(1e30, 0.0), True),
    "-1e30_estimate": (PeerValues(-1e30, 0.0), True),
    "91C_estimate": (PeerValues(91.0, 0.0), True),
    "nan_flux": (PeerValues(33.0, math.nan), True),
    "inf_flux": (PeerValues(33.0, math.inf), True),
    "1e9_flux": (PeerValues(33.0, 1e9), True),
    "subnormal_estimate": (PeerValues(5e-324, 0.0), False),
    "90C_estimate_plausible": (PeerValues(90.0, 0.0), False),
    "-20C_estimate_plausible": (PeerValues(-20.0, 0.0), False),
    "max_flux_plausible": (PeerValues(33.0, 30.0), False),
    "peer_lost": (PeerValues(33.0, 0.0, fresh=False, alive=False), True),
    "none": (None, True),
}


def case_bad_peer(healthy_s: float = 5.0, bad_s: float = 45.0, kinds: tuple[str, ...] | None = None) -> dict:
    """NaN/±inf/absurd/lost peer values: envelope and current limit hold, invalid peers trip."""
    c = Case(
        "control_bad_peer_values",
        "telepresence master with a finger on the pad; after a healthy phase the peer sends NaN, ±inf, "
        "±1e30, "
        "91 °C, NaN/inf/1e9 W flux, a subnormal, the plausible extremes 90 °C / -20 °C / 30 W, or is lost: "
        f"|I| <= 0.8·I_max every step, setpoint within [15, 43] °C, pad within [15, 43] ± {PAD_TOL_C} °C, "
        "invalid or lost peers trip the envelope on the first bad cycle and the current is 0 A within "
        "neutral_timeout_s + 1 s",
    )
    good = PeerValues(33.0, 0.0)
    nh, nb = int(healthy_s / PERIOD_S), int(bad_s / PERIOD_S)
    for name, (bad, must_trip) in BAD_PEERS.items():
        if kinds is not None and name not in kinds:
            continue
        loop = Loop(healthy_s + bad_s)
        for _ in range(nh):
            loop.step(good)
        first_trip_after = None
        zero_after = None
        for k in range(nb):
            loop.step(bad)
            st = loop.last.status.safety
            if first_trip_after is None and ({"peer_invalid", "peer_lost"} & {t.value for t in st.trips}):
                first_trip_after = k
            if zero_after is None and loop.last.current_A == 0.0 and st.state == sf.SafetyState.CUT:
                zero_after = k * PERIOD_S
        loop.check(c, name)
        c.fig(**{f"{name}_trip_after_cycles": first_trip_after, f"{name}_cut_after_s": zero_after})
        if must_trip:
            c.require(
                first_trip_after == 0, f"{name}: tripped on the first bad cycle (after {first_trip_after})"
            )
            c.require(
                zero_after is not None and zero_after <= loop.lim.neutral_timeout_s + 1.0,
                f"{name}: current cut after {zero_after} s <= {loop.lim.neutral_timeout_s + 1.0} s",
            )
        else:
            c.require(first_trip_after is None, f"{name}: plausible value did not trip the peer check")
    return c.result()


def case_saturation_release(saturate_s: float = 180.0, after_s: float = 60.0) -> dict:
    """Minutes of saturation then release: no windup kick (overshoot quantified)."""
    c = Case(
        "control_saturation_release",
        "the peer asks 40 °C, which the pad cannot reach with the current limited to 0.24 A (I_max 0.3 A): "
        "the "
        f"PI saturates for {saturate_s:g} s; then the setpoint drops 1 °C below the plateau: the integrator "
        "is "
        "within the current limit at the release, the current stops heating (< +limit) within 0.05 s of the "
        "moment the envelope's ramped setpoint passes below the estimate, and the pad rises no more than "
        "0.1 °C after the release (no windup kick)",
    )
    lim = sf.SafetyLimits(I_max_A=0.3)
    loop = Loop(saturate_s + after_s + 1, safety=lim)
    n_sat = int(saturate_s / PERIOD_S)
    sat_steps = 0
    for _ in range(n_sat):
        loop.step(PeerValues(40.0, 0.0))
        sat_steps += abs(loop.last.current_A) >= lim.I_limit_A - 1e-12
    plateau = loop.last.status.estimate_C
    pad_at_release = loop.rig.truth().T_contact_face_C
    integral = loop.state.pi.integral_A
    target = plateau - 1.0
    n_after = int(after_s / PERIOD_S)
    left_limit_after = crossed_at = None
    pad_max = -math.inf
    est = np.empty(n_after)
    for k in range(n_after):
        loop.step(PeerValues(target, 0.0))
        st = loop.last.status
        if crossed_at is None and st.setpoint_C < st.estimate_C:
            crossed_at = k * PERIOD_S
        if left_limit_after is None and loop.last.current_A < lim.I_limit_A - 1e-9:
            left_limit_after = k * PERIOD_S
        pad_max = max(pad_max, loop.rig.truth().T_contact_face_C)
        est[k] = loop.last.status.estimate_C
    loop.check(c, "run")
    rise = pad_max - pad_at_release
    undershoot = float(target - est[n_after // 2 :].min())
    delay = (
        (left_limit_after - crossed_at) if left_limit_after is not None and crossed_at is not None else None
    )
    c.fig(
        saturated_fraction=sat_steps / n_sat,
        plateau_estimate_C=plateau,
        integral_at_release_A=integral,
        current_left_limit_after_s=left_limit_after,
        setpoint_below_estimate_after_s=crossed_at,
        stop_heating_delay_s=delay,
        pad_rise_after_release_C=rise,
        undershoot_below_new_setpoint_C=undershoot,
        settled_error_C=float(abs(np.mean(est[-500:]) - target)),
    )
    c.require(
        sat_steps / n_sat >= 0.9,
        f"the PI was saturated {100 * sat_steps / n_sat:.0f} % of the time (>= 90 %)",
    )
    c.require(
        abs(integral) <= lim.I_limit_A + 1e-12, f"integrator {integral:.3g} A within ±{lim.I_limit_A} A"
    )
    c.require(
        delay is not None and delay <= 0.05,
        f"current stopped heating {delay} s after the ramped setpoint passed below the estimate (<= 0.05 s)",
    )
    if integral < 0 < loop.last.current_A or integral <= -lim.I_limit_A + 1e-12:
        c.note(
            f"while saturated at +{lim.I_limit_A} A the integrator sat at {integral:+.3g} A: the "
            "anti-windup clamp "
            "[u_min - p - ff, u_max - p - ff] pins it at the opposite rail whenever kp·e alone exceeds the "
            "limit"
        )
    c.require(rise <= 0.1, f"pad rose {rise:.3f} °C after the release (<= 0.1 °C)")
    return c.result()


def case_sync_loss_bursts(duration_s: float = 120.0, seed: int = 3) -> dict:
    """Stale peer values, lost SYNCs, SYNC bursts: envelope and current limit hold."""
    c = Case(
        "control_sync_loss_bursts",
        "a master fed a random mix of normal cycles, stale peer values (not fresh), lost SYNCs (the rig runs "
        "2..50 periods between steps), SYNC bursts (2..5 steps on the same sample) and peer-setpoint jumps "
        "15..43 °C: |I| <= 0.8·I_max, setpoint within [15, 43] °C, pad within the envelope, and a final peer "
        "loss cuts the current within neutral_timeout_s + 1 s",
    )
    rng = np.random.default_rng(seed)
    loop = Loop(duration_s * 1.6 + 20)
    T_peer = 33.0
    t = 0.0
    counts = {"normal": 0, "stale": 0, "lost_sync": 0, "burst": 0, "jump": 0}
    while t < duration_s:
        kind = rng.choice(["normal", "stale", "lost_sync", "burst", "jump"], p=[0.5, 0.15, 0.15, 0.1, 0.1])
        counts[str(kind)] += 1
        if kind == "normal":
            for _ in range(int(rng.integers(1, 200))):
                T_peer += float(rng.normal(0, 0.02))
                T_peer = min(max(T_peer, 15.0), 43.0)
                loop.step(PeerValues(T_peer, float(rng.normal(0, 0.1))))
                t += PERIOD_S
        elif kind == "stale":
            old = PeerValues(T_peer, 0.0, fresh=False)
            for _ in range(int(rng.integers(1, 50))):
                loop.step(old)
                t += PERIOD_S
        elif kind == "lost_sync":
            k = int(rng.integers(2, 51))
            loop.step(PeerValues(T_peer, 0.0), advance=k)
            t += k * PERIOD_S
        elif kind == "burst":
            n = int(rng.integers(2, 6))
            for i in range(n):
                loop.step(PeerValues(T_peer, 0.0), advance=1 if i == n - 1 else 0)
            t += PERIOD_S
        else:
            T_peer = float(rng.uniform(15.0, 43.0))
            loop.step(PeerValues(T_peer, 0.0))
            t += PERIOD_S
    c.fig(events=counts, simulated_s=t)
    cut_after = None
    for k in range(int((loop.lim.neutral_timeout_s + 5) / PERIOD_S)):
        loop.step(PeerValues(T_peer, 0.0, fresh=False, alive=False))
        if (
            cut_after is None
            and loop.last.current_A == 0.0
            and loop.last.status.safety.state == sf.SafetyState.CUT
        ):
            cut_after = k * PERIOD_S
    loop.check(c, "run")
    c.fig(cut_after_peer_loss_s=cut_after)
    c.require(
        cut_after is not None and cut_after <= loop.lim.neutral_timeout_s + 1.0,
        f"cut {cut_after} s after the peer loss (<= {loop.lim.neutral_timeout_s + 1.0} s)",
    )
    return c.result()


def _real32_diffs(c: Case, sc, duration_s: float, tag: str) -> dict[str, tuple[float, float]]:
    """Run ``sc`` offline exact and REAL32-rounded; per side (max |ΔI| A, max |Δestimate| °C), figures
    ``tag``."""
    a = run_offline_session(sc, duration_s=duration_s, rounding="none")
    b = run_offline_session(sc, duration_s=duration_s, rounding="real32")
    ra, rb = a.recording, b.recording
    out = {}
    for side in ("m", "s"):
        dIs = np.abs(ra.col(f"{side}_current_A") - rb.col(f"{side}_current_A"))
        dI = float(np.nanmax(dIs))
        dT = float(np.nanmax(np.abs(ra.col(f"{side}_estimate_C") - rb.col(f"{side}_estimate_C"))))
        c.fig(
            **{
                f"{tag}{side}_max_current_diff_A": dI,
                f"{tag}{side}_max_estimate_diff_C": dT,
                f"{tag}{side}_median_current_diff_A": float(np.nanmedian(dIs)),
                f"{tag}{side}_p99_current_diff_A": float(np.nanpercentile(dIs, 99)),
                f"{tag}{side}_max_current_diff_at_s": float(ra.col("t_s")[int(np.nanargmax(dIs))]),
            }
        )
        out[side] = (dI, dT)
    return out


def case_real32(duration_s: float = 15.0) -> dict:
    """REAL32 rounding of the exchanged values changes the session by less than 1e-3, and by no more than
    two ADC steps' worth where the rigs quantise."""
    c = Case(
        "control_real32_rounding",
        "the guiatni §5.3 scene run offline twice, the exchanged estimates and fluxes exact or rounded to "
        "REAL32 (as the PDOs carry them). With a continuous measurement chain (ADC quantisation off, noise "
        "on): both sides' currents differ by <= 1e-3 A and estimates by <= 1e-3 °C at every step (the "
        "rounding, ~2e-6 °C at 33 °C, is not amplified by the loop). With the rigs' 16-bit ADCs: a 2e-6 °C "
        "difference can flip an ADC code (1.5 mK), a step the loop sees as it would see noise; estimates "
        "then differ by <= 2 ADC steps and currents by <= 2 steps through the proportional gains "
        "(kp·T_lsb + kpQ·Q_lsb per step)",
    )
    sc = sim.load_scene("probe_touches_al_steel_wood")
    continuous = dataclasses.replace(sc, noise=dataclasses.replace(sc.noise, T_lsb_C=0.0, Q_lsb_W=0.0))
    for side, (dI, dT) in _real32_diffs(c, continuous, duration_s, "").items():
        c.require(dI <= 1e-3, f"{side} (no ADC): currents differ by {dI:.3g} A <= 1e-3 A")
        c.require(dT <= 1e-3, f"{side} (no ADC): estimates differ by {dT:.3g} °C <= 1e-3 °C")
    T_lsb, Q_lsb = sc.noise.T_lsb_C, sc.noise.Q_lsb_W
    for side, (dI, dT) in _real32_diffs(c, sc, duration_s, "adc_").items():
        p = default_params(Role.MASTER if side == "m" else Role.SLAVE)
        dI_max = 2.0 * (abs(p.kp_A_per_C) * T_lsb + abs(p.kpQ_A_per_W) * Q_lsb)
        c.fig(**{f"adc_{side}_bound_current_A": dI_max, f"adc_{side}_bound_estimate_C": 2.0 * T_lsb})
        c.require(
            dI <= dI_max,
            f"{side} (16-bit ADC): currents differ by {dI:.3g} A <= {dI_max:.3g} A (2 ADC steps)",
        )
        c.require(
            dT <= 2.0 * T_lsb, f"{side} (16-bit ADC): estimates differ by {dT:.3g} °C <= {2 * T_lsb:.3g} °C"
        )
    return c.result()


CASES = {
    "control_bad_peer_values": (case_bad_peer, {}, {"bad_s": 35.0}),
    "control_saturation_release": (case_saturation_release, {}, {"saturate_s": 120.0, "after_s": 30.0}),
    "control_sync_loss_bursts": (case_sync_loss_bursts, {"duration_s": 600.0}, {"duration_s": 120.0}),
    "control_real32_rounding": (case_real32, {"duration_s": 30.0}, {"duration_s": 12.0}),
}
