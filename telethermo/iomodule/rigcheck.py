"""Commissioning before a finger goes on the pad (issue 24 item 3): the wiring of a RIG.toml checked step by
step against the modules themselves, with small, safe excitations (docs/hardware.md, "Rig check").

The check talks to the I/O modules only (the controller node is not yet trusted; nothing is written to it).
It commissions the modules as the I/O rig driver does (:class:`.iorig.IoRig`), produces the SYNCs itself
(one per loop period of plant time, each answered by the modules' TPDOs before the next) and stops at the
first step that fails with one :class:`Finding`: the fault's key (``sign:Q_W``, ``scale:current_A``,
``open:T_sensor_C``, ``swap:T_sensor_C:T_sink_C``, ``sampling:io``, ...) and one line saying what is wrong
and how to fix it. The steps:

1. ``sampling``: each module's sampling object reads at most the loop period, and its inputs really convert
   that often (new codes counted over :data:`SAMPLING_SYNCS` SYNCs while the drive toggles 0 / a small
   current); 400 ms, the real modules' default, is the trap.
2. ``rest`` (drive at 0 A): every signal present (not at a sentinel: open or shorted sensor) and plausible
   for a pad in air at room temperature (:data:`REST_RANGES`): a temperature at minus room temperature is a
   reversed sign, one at ten times it a ×10 gain, exactly 0 V a short.
3. ``step``: +:data:`STEP_FRACTION` of ``limit_A`` for :data:`STEP_S` s (stopped early if the pad moves by
   more than :data:`STEP_ABORT_C`), then 0 A. The current monitor must read the commanded current (polarity
   and scale; a reversed monitor on a pad that heats, a reversed drive on a pad that cools); the thermocouple
   must rise by a plausible amount (:data:`STEP_RISE_C`) more than the heat sink; the heat flux must turn
   positive (telethermo/rig.py: Q_W > 0 is heat flowing from the TEM into the pad) by :data:`STEP_FLUX_W`.
   A signal that does not move while another one moves the way it should names the two as swapped.

The windows are those of a pad in air with a TEM of a few amperes (the simulated rig: +1.2 °C and +0.13 W
after 1 s at 0.3 A); a lab whose pad is much heavier or lighter reads the step's figures in the report.
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass, field
from typing import Callable

import canopen

from telethermo.iomodule.iorig import IoRig, IoRigError
from telethermo.iomodule.rigconfig import RigConfig

SAMPLING_SYNCS = 40
STEP_FRACTION, STEP_S, STEP_ABORT_C = 0.1, 1.0, 8.0
#: plausible values at rest (drive at 0 A, nothing on the pad), by signal; current: ± limit_A × 0.02
REST_RANGES = {"T_sensor_C": (5.0, 50.0), "T_sink_C": (5.0, 50.0), "Q_W": (-0.5, 0.5), "force_N": (-0.5, 0.5)}
#: plausible responses to the step: thermocouple rise, °C; heat flux, W (mean of the last quarter)
STEP_RISE_C, STEP_FLUX_W = (0.2, 5.0), (0.02, 0.5)
TEMPERATURES = ("T_sensor_C", "T_sink_C")


@dataclass(frozen=True)
class Finding:
    """One wiring fault: ``key`` names it (``kind:signal``), ``line`` says what is wrong and how to fix it."""

    step: str
    key: str
    line: str


class RigCheckFailed(Exception):
    """The check stopped at a fault (:attr:`finding`)."""

    def __init__(self, finding: Finding):
        super().__init__(finding.line)
        self.finding = finding


@dataclass
class Report:
    """What the check measured (filled as it goes; complete when it passed)."""

    sampling_ms: dict[str, float] = field(default_factory=dict)
    rest: dict[str, float] = field(default_factory=dict)
    step_A: float = 0.0
    step: dict[str, float] = field(default_factory=dict)

    def lines(self) -> list[str]:
        out = [
            "sampling: "
            + ", ".join(f"module {m} new inputs every {v:.0f} ms" for m, v in self.sampling_ms.items())
        ]
        out.append("at rest (0 A): " + ", ".join(f"{k} {v:.3g}" for k, v in self.rest.items()))
        out.append(
            f"step {self.step_A:+.2f} A for {STEP_S:g} s: "
            + ", ".join(f"{k} {v:+.3g}" for k, v in self.step.items())
        )
        return out


def _fail(step: str, key: str, line: str) -> RigCheckFailed:
    return RigCheckFailed(Finding(step, key, line))


class RigCheck:
    """``RigCheck(config, network, controller_id=..., period_s=..., counter_overflow=...).run()``: the
    :class:`Report` of a rig that passed, or :class:`RigCheckFailed` naming the first fault."""

    def __init__(
        self,
        config: RigConfig,
        network: canopen.Network,
        *,
        controller_id: int,
        period_s: float,
        counter_overflow: int = 0,
        sdo_timeout_s: float = 1.0,
        progress: Callable[[str], None] = lambda _: None,
    ):
        self.config = config
        self.network = network
        self.period_s = float(period_s)
        self.overflow = int(counter_overflow)
        self.progress = progress
        self.rig = IoRig(
            config,
            transport=None,
            network=network,
            controller_id=controller_id,
            period_s=period_s,
            lockstep=True,
            sdo_timeout_s=sdo_timeout_s,
        )
        self.report = Report()
        self._counter = 0

    # ------------------------------------------------------------------ plumbing
    def _sync(self) -> None:
        """One SYNC and the inputs it brings (the plant advances one loop period)."""
        if self.overflow:
            self._counter = self._counter % self.overflow + 1
            self.network.sync.transmit(self._counter)
        else:
            self.network.sync.transmit()
        before = self.rig.timeouts
        sample = self.rig.read()
        if self.rig.timeouts > before:
            raise _fail(
                "inputs",
                "inputs",
                f"{self.config.source}: the modules' TPDOs did not answer a SYNC "
                f"within {self.rig.timeout_s:g} s: check the modules' node_id and that nothing else "
                "drives them",
            )
        self.sample = sample

    def _values(self) -> dict[str, float]:
        s = self.sample
        vals = {"T_sensor_C": s.T_sensor_C, "Q_W": s.Q_W, "current_A": s.current_A, "T_sink_C": s.T_sink_C}
        counts = self.rig.counts()
        for name in ("contact", "force_N"):
            if name in self.config.signals:
                vals[name] = self.config.signals[name].value(counts[name])
        return vals

    def _where(self, name: str) -> str:
        s = self.config.signals[name]
        return f"signals.{name} (module {s.module} 0x{s.index:04X}:{s.subindex})"

    # ------------------------------------------------------------------ steps
    def quiet_bus(self, listen_s: float = 0.3) -> None:
        """No other SYNC producer (a controller already driving the modules): the check must own the SYNC."""
        seen: list[int] = []
        self.network.subscribe(0x80, lambda cob, data, ts: seen.append(cob))
        try:
            time.sleep(listen_s)
        finally:
            self.network.unsubscribe(0x80)
        if seen:
            raise _fail(
                "bus",
                "sync",
                "another node sends SYNC (a controller running with --rig io?): stop "
                "it before rig check; the check drives the modules itself",
            )

    def run(self) -> Report:
        self.quiet_bus()
        try:
            self.progress("commissioning the modules (as the I/O rig driver does)")
            try:
                self.rig.start()
            except IoRigError as exc:
                raise _fail("commission", "commission", str(exc)) from None
            self.progress("sampling period of each module")
            self._sampling()
            self.progress("every signal at rest (0 A)")
            self._rest()
            self.progress("current step: polarity, scale, thermocouple, heat flux, heat sink")
            self._step()
            return self.report
        finally:
            self.rig.close()

    def _sampling(self) -> None:
        cfg, period_ms = self.config, self.period_s * 1e3
        for name, mod in cfg.modules.items():
            if mod.sampling_index is None:
                continue
            node = self.rig.nodes[name]
            obj = node.object_dictionary[mod.sampling_index]
            var = obj if isinstance(obj, canopen.objectdictionary.ODVariable) else obj[0]
            got = int(var.decode_raw(node.sdo.upload(mod.sampling_index, 0)))
            if got > period_ms:
                raise _fail(
                    "sampling",
                    f"sampling:{name}",
                    f"module {name} (node {mod.node_id}): sampling "
                    f"period 0x{mod.sampling_index:04X} = {got} ms, the {period_ms:g} ms loop needs "
                    f"<= "
                    f"{period_ms:g} ms: set modules.{name}.sampling_ms",
                )
        changes = {name: 0 for name in cfg.modules}
        last = None
        small = STEP_FRACTION * 0.5 * cfg.drive.limit_A
        for k in range(SAMPLING_SYNCS):
            self.rig.apply_current(small if k % 2 == 0 else 0.0)
            self._sync()
            counts = self.rig.counts()
            if last is not None:
                for name in cfg.modules:
                    own = [s for s, sig in cfg.signals.items() if sig.module == name]
                    if own and any(counts[s] != last[s] for s in own):
                        changes[name] += 1
            last = counts
        self.rig.apply_current(0.0)
        for name, n in changes.items():
            if not any(sig.module == name for sig in cfg.signals.values()):
                continue
            every_ms = (SAMPLING_SYNCS - 1) * period_ms / max(n, 1)
            self.report.sampling_ms[name] = every_ms
            if every_ms > 1.5 * period_ms:
                mod = cfg.modules[name]
                seen = (
                    f"new inputs only every ~{every_ms:.0f} ms ({n} in {SAMPLING_SYNCS - 1} SYNCs of "
                    f"{period_ms:g} ms)"
                    if n
                    else f"no new inputs in {SAMPLING_SYNCS - 1} SYNCs of {period_ms:g} ms (>= "
                    f"{every_ms:.0f} ms)"
                )
                raise _fail(
                    "sampling",
                    f"sampling:{name}",
                    f"module {name} (node {mod.node_id}): {seen}, "
                    f"the loop needs <= {period_ms:g} ms: set the module's own sampling object "
                    f"(modules.{name}.sampling_index, now "
                    f"{'none' if mod.sampling_index is None else f'0x{mod.sampling_index:04X}'}) "
                    "from its manual",
                )

    def _rest(self) -> None:
        cfg = self.config
        self.rig.apply_current(0.0)
        for _ in range(3):
            self._sync()
        counts, vals = self.rig.counts(), self._values()
        for name, sig in cfg.signals.items():
            code = counts[name]
            if code in sig.sentinels:
                kind = "open" if code > 0 else "short"
                what = (
                    "open circuit or positive overload: an open thermocouple, a loose wire, or an "
                    "amplifier gain far too high"
                    if code > 0
                    else "negative overload: a shorted or reversed sensor, or an amplifier gain far too high"
                )
                raise _fail(
                    "rest",
                    f"{kind}:{name}",
                    f"{self._where(name)} reads {code}, its sentinel: "
                    f"{what}: check that input's wiring and amplifier",
                )
        self.report.rest = {k: round(v, 4) for k, v in vals.items()}
        for name in TEMPERATURES:
            v, (lo, hi) = vals[name], REST_RANGES[name]
            if lo <= v <= hi:
                continue
            if counts[name] == 0:
                raise _fail(
                    "rest",
                    f"short:{name}",
                    f"{self._where(name)} reads exactly 0 V ({v:g} °C): a shorted sensor or amplifier "
                    "input: check its wiring",
                )
            if lo <= -v <= hi:
                raise _fail(
                    "rest",
                    f"sign:{name}",
                    f"{self._where(name)} reads {v:.1f} °C at room temperature: its sign is reversed: "
                    f"swap the amplifier's leads or set signals.{name}.sign = {-cfg.signals[name].sign}",
                )
            for factor in (10.0, 0.1):
                if lo <= v / factor <= hi:
                    raise _fail(
                        "rest",
                        f"scale:{name}",
                        f"{self._where(name)} reads {v:.1f} °C at room "
                        f"temperature, {factor:g}x a plausible value: fix signals.{name}.gain "
                        f"(now {cfg.signals[name].gain:g}) or the amplifier's range",
                    )
            raise _fail(
                "rest",
                f"range:{name}",
                f"{self._where(name)} reads {v:.1f} °C at rest, expected "
                f"{lo:g}..{hi:g} °C: check its scaling (gain, offset_V) and wiring",
            )
        limit = 0.02 * cfg.drive.limit_A
        if abs(vals["current_A"]) > limit:
            raise _fail(
                "rest",
                "offset:current_A",
                f"{self._where('current_A')} reads {vals['current_A']:.3f} A with the drive at 0 A "
                f"(> {limit:g}): fix its offset_V or the drive's offset_V",
            )
        for name in ("Q_W", "force_N"):
            if name in vals and not REST_RANGES[name][0] <= vals[name] <= REST_RANGES[name][1]:
                raise _fail(
                    "rest",
                    f"range:{name}",
                    f"{self._where(name)} reads {vals[name]:.3f} at rest with nothing on the pad, "
                    f"expected {REST_RANGES[name]}: check its offset_V, gain and wiring",
                )
        if "contact" in vals and vals["contact"] >= cfg.signals["contact"].threshold:
            raise _fail(
                "rest",
                "contact",
                f"{self._where('contact')} reads touched ({vals['contact']:.2f}) "
                "with nothing on the pad: take the finger off, or fix its sign/threshold",
            )

    def _step(self) -> None:
        cfg, rep = self.config, self.report
        step_A = STEP_FRACTION * cfg.drive.limit_A
        rep.step_A = step_A
        rest = self._values()
        n = max(4, round(STEP_S / self.period_s))
        tail: list[dict[str, float]] = []
        try:
            for k in range(n):
                self.rig.apply_current(step_A)
                self._sync()
                vals = self._values()
                if any(not math.isfinite(v) for v in vals.values()):
                    bad = [s for s, v in vals.items() if not math.isfinite(v)][0]
                    raise _fail(
                        "current step",
                        f"open:{bad}",
                        f"{self._where(bad)} went to its sentinel "
                        f"during a {step_A:.2f} A step: a loose wire or an amplifier range too small",
                    )
                if max(abs(vals[t] - rest[t]) for t in TEMPERATURES) > STEP_ABORT_C:
                    break
                if k >= n - n // 4:
                    tail.append(vals)
        finally:
            self.rig.apply_current(0.0)
        end = self._values()
        mean = {s: statistics.fmean(v[s] for v in tail) if tail else end[s] for s in end}
        d = {s: end[s] - rest[s] for s in end}
        d["current_A"] = mean["current_A"]
        d["Q_W"] = mean["Q_W"] - rest["Q_W"]
        rep.step = {
            "current_A": round(d["current_A"], 4),
            "dT_sensor_C": round(d["T_sensor_C"], 4),
            "dT_sink_C": round(d["T_sink_C"], 4),
            "dQ_W": round(d["Q_W"], 4),
        }
        self._check_current(step_A, d, mean)
        self._check_thermocouple(d)
        self._check_flux(d)

    def _check_current(self, step_A: float, d: dict[str, float], mean: dict[str, float]) -> None:
        cfg, got = self.config, d["current_A"]
        ratio = got / step_A
        dT = d["T_sensor_C"]
        if abs(ratio) < 0.2:
            for other, v in mean.items():
                if other != "current_A" and abs(abs(v) - step_A) < 0.1 * step_A:
                    raise _fail(
                        "current step",
                        f"swap:current_A:{other}",
                        f"{self._where('current_A')} "
                        f"reads {got:.3f} A for {step_A:.2f} A commanded while {self._where(other)} "
                        f"reads {v:.3f}: the two inputs are swapped: exchange them in RIG.toml or "
                        "the wires",
                    )
            if abs(dT) < STEP_RISE_C[0]:
                raise _fail(
                    "current step",
                    "drive",
                    f"drive (module {cfg.drive.module} "
                    f"0x{cfg.drive.index:04X}:{cfg.drive.subindex}): {step_A:.2f} A commanded, no "
                    "current measured and the pad did not move: check the amplifier's enable, its "
                    "wiring to the TEM and the drive object",
                )
            raise _fail(
                "current step",
                "missing:current_A",
                f"{self._where('current_A')} reads {got:.3f} A "
                f"while {step_A:.2f} A moves the pad: the current monitor is not on that input",
            )
        if ratio < 0:
            if dT < 0:
                raise _fail(
                    "current step",
                    "sign:drive",
                    f"drive: {step_A:+.2f} A commanded cooled the pad ({dT:+.2f} °C) and the monitor "
                    f"reads {got:+.3f} A: the current amplifier or the TEM is wired reversed: "
                    f"swap the TEM's leads or set drive.sign = {-cfg.drive.sign}",
                )
            raise _fail(
                "current step",
                "sign:current_A",
                f"{self._where('current_A')} reads {got:+.3f} A for {step_A:+.2f} A commanded while "
                f"the pad heats ({dT:+.2f} °C): the monitor's sign is reversed: "
                f"set signals.current_A.sign = {-cfg.signals['current_A'].sign}",
            )
        if abs(ratio - 1) > 0.2:
            raise _fail(
                "current step",
                "scale:current_A",
                f"{self._where('current_A')} reads {got:.3f} A "
                f"for {step_A:.2f} A commanded ({ratio:.2f}x): fix signals.current_A.gain (now "
                f"{cfg.signals['current_A'].gain:g}) or drive.gain (the amplifier's A/V, now "
                f"{cfg.drive.gain:g})",
            )

    def _check_thermocouple(self, d: dict[str, float]) -> None:
        cfg, dT, dS = self.config, d["T_sensor_C"], d["T_sink_C"]
        lo, hi = STEP_RISE_C
        if abs(dT) < lo and abs(dS) >= lo:
            raise _fail(
                "current step",
                "swap:T_sensor_C:T_sink_C",
                f"{self._where('T_sensor_C')} did not move ({dT:+.2f} °C) under the step while "
                f"{self._where('T_sink_C')} did ({dS:+.2f} °C): "
                "the two inputs are swapped: exchange them in RIG.toml or the wires",
            )
        if dT < -lo:
            raise _fail(
                "current step",
                "sign:T_sensor_C",
                f"{self._where('T_sensor_C')} fell by {-dT:.2f} °C while a heating current flowed: "
                f"its sign is reversed: set signals.T_sensor_C.sign = "
                f"{-cfg.signals['T_sensor_C'].sign} or swap the amplifier's leads",
            )
        if not lo <= dT <= hi:
            raise _fail(
                "current step",
                "scale:T_sensor_C",
                f"{self._where('T_sensor_C')} rose by {dT:.3f} °C in {STEP_S:g} s at "
                f"{STEP_FRACTION:.0%} of limit_A, expected {lo:g}..{hi:g} °C for a pad in air: "
                "check signals.T_sensor_C.gain and that the thermocouple is on the pad",
            )
        if abs(dS) > abs(dT) / 3:
            raise _fail(
                "current step",
                "T_sink_C",
                f"{self._where('T_sink_C')} moved {dS:+.2f} °C, as much as the pad ({dT:+.2f} °C): "
                "the heat-sink sensor is not on the heat sink (or on the wrong input)",
            )

    def _check_flux(self, d: dict[str, float]) -> None:
        cfg, dQ = self.config, d["Q_W"]
        lo, hi = STEP_FLUX_W
        if abs(dQ) < lo:
            raise _fail(
                "current step",
                "missing:Q_W",
                f"{self._where('Q_W')} moved {dQ:+.4f} W under a heating step, expected "
                f"{lo:g}..{hi:g} W: the flux sensor is not on that input or not in the stack",
            )
        if dQ < 0:
            raise _fail(
                "current step",
                "sign:Q_W",
                f"{self._where('Q_W')} went {dQ:+.3f} W while the pad heated; the convention "
                "(telethermo/rig.py) is Q_W > 0 for heat flowing from the TEM into the pad: "
                f"set signals.Q_W.sign = {-cfg.signals['Q_W'].sign}",
            )
        if dQ > hi:
            raise _fail(
                "current step",
                "scale:Q_W",
                f"{self._where('Q_W')} went {dQ:+.3f} W under a {STEP_FRACTION:.0%} step, "
                f"expected {lo:g}..{hi:g} W for a pad in air: fix signals.Q_W.gain "
                f"(now {cfg.signals['Q_W'].gain:g}) or the amplifier's range",
            )
