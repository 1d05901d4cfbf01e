"""A simulated rig: the plant of sim.plant behind the project's rig interface
(telethermo.rig.SimulatedRig)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from telethermo.sim.bodies import Segment, sensor_segment
from telethermo.sim.materials import material
from telethermo.sim.measurement import Channel, NoiseParams
from telethermo.sim.plant import Body, Config, GridSettings
from telethermo.sim.tem import RigParams
from telethermo.units import KELVIN
from telethermo.rig import RigSample

_SNAP_S = 1e-9


@dataclass(frozen=True, slots=True)
class RigTruth:
    """The simulator's ground truth at the rig's current time (what no controller can see).

    Attributes:
        t_s: time, s.
        T_pad_C: TEM pad-side plate, °C.
        T_surface_C: surface of what touches the pad (finger skin / object face), °C; NaN when nothing does.
        T_sensor_true_C: flux sensor mid-plane (the thermocouple) before noise and filter, °C.
        Q_true_W: heat flow through the sensor towards the contact (thickness mean), W.
        T_sink_C: heat sink, °C.
        touching: name of the body touching the pad, or None.
        force_N: contact force, N.
        T_contact_face_C: top face of the flux sensor (the pad surface a body touches), °C.
        current_A: drive current, A.
        Q_into_body_W: heat flow across the contact into the touching body (finger / object), W; > 0 heats
            the body; 0 when nothing touches.
    """

    t_s: float
    T_pad_C: float
    T_surface_C: float
    T_sensor_true_C: float
    Q_true_W: float
    T_sink_C: float
    touching: str | None
    force_N: float
    T_contact_face_C: float = math.nan
    current_A: float = 0.0
    Q_into_body_W: float = 0.0


def plate_heats(rows: tuple, alpha_V_K: float, tau_V_K: float, R_ohm: float, I_A, Ts_C, Tp_C, y1, y2):
    """Electrical heat into the (sink, pad) plates at the start (u0, u1) and the end (v0, v1) of one
    exact step, W.

    The plate heats are u = U·[T_s, T_p] + w (sim.tem docstring; T in °C, the Kelvin offset in w), and the
    plate temperatures at the end of the step solve p' = P·y_n + P·B1·(U·p' + w) (2×2, exactly). ``rows``:
    the step's scalars of the two plate rows (sim.plant.Config.step); ``Ts_C``, ``Tp_C``: the plates now;
    ``y1``, ``y2``: the plate rows of Phi·x. Plain arithmetic, so the arguments may be floats (one rig) or
    numpy arrays (many current sequences at once, telethermo/offline/bound.py) with the same operations in the
    same order.
    """
    c1, a10, a11, b10, b11, c2, a20, a21, b20, b21 = rows
    aI = alpha_V_K * I_A
    hT = 0.5 * tau_V_K * I_A
    J = 0.5 * R_ohm * I_A * I_A
    U00, U01, w0 = -aI + hT, -hT, -aI * KELVIN + J
    U10, U11, w1 = -hT, aI + hT, aI * KELVIN + J
    u0 = U00 * Ts_C + U01 * Tp_C + w0
    u1 = U10 * Ts_C + U11 * Tp_C + w1
    r0 = y1 + c1 + a10 * u0 + a11 * u1 + b10 * w0 + b11 * w1
    r1 = y2 + c2 + a20 * u0 + a21 * u1 + b20 * w0 + b21 * w1
    m00 = 1.0 - (b10 * U00 + b11 * U10)
    m01 = -(b10 * U01 + b11 * U11)
    m10 = -(b20 * U00 + b21 * U10)
    m11 = 1.0 - (b20 * U01 + b21 * U11)
    det = m00 * m11 - m01 * m10
    Ts1 = (r0 * m11 - m01 * r1) / det
    Tp1 = (m00 * r1 - m10 * r0) / det
    return u0, u1, U00 * Ts1 + U01 * Tp1 + w0, U10 * Ts1 + U11 * Tp1 + w1


class SimRig:
    """One simulated rig (master display or slave probe); implements telethermo.rig.SimulatedRig.

    Time advances only in :meth:`advance`; contact make/break inside a step is honoured exactly (the step is
    split at the event). :meth:`read` returns the sample taken at the end of the last advance.
    """

    def __init__(
        self,
        params: RigParams,
        bodies: dict[str, Body],
        schedule,
        *,
        ambient_C: float,
        period_s: float,
        noise: NoiseParams,
        seed: int | None,
        name: str = "rig",
        prune: bool = True,
        pruning: list[str] | None = None,
        grid: GridSettings | None = None,
        start: str | float | None = None,
    ) -> None:
        self.name = name
        self.params = params
        self.period_s = float(period_s)
        self.I_max_A = float(params.tem.I_max_A)
        self.ambient_C = float(ambient_C)
        self.bodies = bodies
        self.schedule = schedule
        self.prune = prune
        self._pruning = list(pruning or [])
        grid = grid or GridSettings(t_min_s=self.period_s)
        self.grid = grid
        self.sensor: Segment = sensor_segment(
            "sensor",
            material(params.sensor_material),
            params.sensor_thickness_m,
            params.area_m2,
            grid.t_min_s,
            grid.ratio,
            grid.cells_per_length,
            params.sensor_cells,
        )
        self._configs: dict[tuple, Config] = {}
        tem = params.tem
        self._alpha, self._R, self._tau = tem.alpha_V_K, tem.R_ohm, tem.tau_V_K
        self.t_s = 0.0
        self.I = 0.0
        self.E_el_J = 0.0
        self._touch = None
        self._force, self._contact = 0.0, False
        cfg = self._config(None)
        self.cfg = cfg
        self.x = np.append(np.full(cfg.n, self.ambient_C), 0.0)
        self._stored0 = self._stored_total()
        fs = 1.0 / self.period_s
        rng = np.random.default_rng(seed)
        on = noise.enabled
        self._chT = Channel(noise.T_sigma_C if on else 0.0, noise.T_lsb_C, noise.cutoff_Hz, fs, rng)
        self._chQ = Channel(noise.Q_sigma_W if on else 0.0, noise.Q_lsb_W, noise.cutoff_Hz, fs, rng)
        self._switch()
        self._next_event = self.schedule.next_event_after(self.t_s)
        #: fault injection (:meth:`detach_sensor`): from this time on the sensor head is off the pad, s
        self.detached_at_s = math.inf
        self._detach_tau_s = 3.0
        self._detached_T_C = math.nan
        if start is not None:
            self._settle(start)
        self._stored0 = self._stored_total()
        self._sample()

    # ---- configuration -------------------------------------------------------------------------------
    def _config(self, touch) -> Config:
        key = (touch.body, touch.force_N) if touch is not None else None
        cfg = self._configs.get(key)
        if cfg is None:
            body = self.bodies[touch.body] if touch is not None else None
            cfg = Config(self.params, self.sensor, self.ambient_C, body, touch.force_N if touch else 0.0)
            self._configs[key] = cfg
        return cfg

    def _switch(self) -> None:
        """Re-assemble for the contact state at the current time (detach / attach bodies)."""
        touch = self.schedule.at(self.t_s + _SNAP_S)
        if touch == self._touch:
            return
        old, x = self.cfg, self.x
        base = 3 + self.sensor.n
        E_out = x[-1]
        if old.body is not None:
            b = old.body
            b.x[: b.n] = x[base : base + b.n]
            b.t_s = self.t_s
            b.attached = False
        new = self._config(touch)
        parts = [x[:base]]
        if new.body is not None:
            b = new.body
            b.advance_detached(self.t_s)
            parts.append(b.x[: b.n])
            b.attached = True
        parts.append([E_out])
        self.x = np.concatenate(parts)
        self.cfg = new
        self._touch = touch
        self._force = touch.force_N if touch is not None else 0.0
        self._contact = self._force > self.params.detect_threshold_N

    # ---- settled start -------------------------------------------------------------------------------
    def _steady_at(self, I_A: float) -> np.ndarray:
        """Steady state of the present contact state at a constant current I_A (the plate heats are linear in
        the plate temperatures at a fixed current: one linear solve)."""
        sysm = self.cfg.system
        a, hT, J = self._alpha * I_A, 0.5 * self._tau * I_A, 0.5 * self._R * I_A * I_A
        K = sysm.K.copy()
        rhs = -sysm.s.copy()
        i_s, i_p = self.cfg.i_s, self.cfg.i_p
        K[i_s, i_s] += -a + hT
        K[i_s, i_p] += -hT
        K[i_p, i_s] += -hT
        K[i_p, i_p] += a + hT
        rhs[i_s] -= -a * KELVIN + J
        rhs[i_p] -= a * KELVIN + J
        return np.linalg.solve(K, rhs)

    def _settle(self, start: str | float) -> None:
        """Put the rig in the steady state a long-running display would be in at t = 0.

        ``"finger"``: the finger (attached at t = 0) rests on a display that renders air: the pad draws from
        it exactly the heat the finger loses to air at its natural (steady, in air) state, so the finger's
        profile is its natural one. A number (°C): the sensor's mid-plane held at that temperature. The
        constant current that does it is found by the secant method (the steady state is smooth in I)."""
        cfg = self.cfg
        n = cfg.n
        if start == "finger":
            body = cfg.body
            if body is None or body.spec.kind != "finger":
                raise ValueError("SimRig: start 'finger' needs the finger on the pad at t = 0")
            loss_W = float(body.air.G_W_K) * (body.surface_C() - body.ambient_C)

            def resid(I: float) -> float:
                return float(cfg.body_q_f @ self._steady_at(I) + cfg.body_q_f0) + loss_W
        elif isinstance(start, (int, float)) and not isinstance(start, bool):
            T_target = float(start)

            def resid(I: float) -> float:
                return float(self._steady_at(I)[cfg.i_mid]) - T_target
        else:
            raise ValueError(f"SimRig: start: expected 'finger' or a temperature in °C, got {start!r}")
        I0, I1 = 0.0, 0.1
        r0, r1 = resid(I0), resid(I1)
        for _ in range(50):
            if abs(r1) < 1e-12 or r1 == r0:
                break
            I0, I1, r0 = I1, I1 - r1 * (I1 - I0) / (r1 - r0), r1
            r1 = resid(I1)
        if not (abs(I1) <= self.I_max_A and abs(r1) < 1e-6):
            raise ValueError(
                f"SimRig: no steady start {start!r} within ±{self.I_max_A} A (residual {r1:.3g})"
            )
        self.I = I1
        self.x = np.append(self._steady_at(I1)[:n], 0.0)

    # ---- rig interface -------------------------------------------------------------------------------
    def apply_current(self, current_A: float) -> None:
        """Command the drive current, A; the drive clips it to ±I_max_A (NaN is refused: treated as 0)."""
        c = float(current_A)
        if not math.isfinite(c):
            c = 0.0
        self.I = max(-self.I_max_A, min(self.I_max_A, c))

    def read(self) -> RigSample:
        return self._last

    def advance(self, dt_s: float) -> None:
        """Integrate the plant by dt_s seconds holding the current, then take one sample."""
        if not dt_s > 0:
            raise ValueError(f"advance: dt_s must be > 0, got {dt_s!r}")
        t_end = self.t_s + dt_s
        if self._next_event > t_end + _SNAP_S:  # common case: no make/break in this step
            self._integrate(dt_s)
            self.t_s = t_end
        while self.t_s < t_end - _SNAP_S:
            t_ev = self._next_event
            if t_ev < t_end - _SNAP_S:
                self._integrate(t_ev - self.t_s)
                self.t_s = t_ev
            else:
                self._integrate(t_end - self.t_s)
                self.t_s = t_end
            if abs(self.t_s - t_ev) <= _SNAP_S or self.t_s > t_ev:
                self._switch()
                self._next_event = self.schedule.next_event_after(self.t_s + _SNAP_S)
        if not self.prune:
            for b in self.bodies.values():
                if not b.attached:
                    b.advance_detached(self.t_s, cache=True)
        self._sample()

    def _integrate(self, dt: float) -> None:
        Phi, c, Bcat, rows = self.cfg.step(dt)
        x = self.x
        I = self.I
        y = Phi @ x
        if I == 0.0:
            y += c
            self.x = y
            return
        u0, u1, v0, v1 = plate_heats(
            rows, self._alpha, self._tau, self._R, I, x.item(1), x.item(2), y.item(1), y.item(2)
        )
        y += Bcat @ np.array((1.0, u0, u1, v0, v1))
        self.x = y
        self.E_el_J += 0.5 * dt * (u0 + u1 + v0 + v1)

    def detach_sensor(self, at_s: float, *, tau_s: float = 3.0) -> None:
        """Fault injection: from ``at_s`` on, the sensor head (thermocouple and flux sensor) is off the pad.
        Its thermocouple relaxes from where it was towards the ambient air with time constant ``tau_s`` (s)
        and no heat flows through its flux sensor (it reads 0 W), through the same noisy measurement chain;
        the plant is unchanged (the pad and what touches it go on as before, now unseen)."""
        self.detached_at_s = float(at_s)
        self._detach_tau_s = float(tau_s)

    def _sample(self) -> None:
        cfg, x = self.cfg, self.x
        T, Q = x.item(cfg.i_mid), float(cfg.q_full @ x) + cfg.q_f0
        if self.t_s >= self.detached_at_s:
            prev = self._detached_T_C if math.isfinite(self._detached_T_C) else T
            T = self.ambient_C + (prev - self.ambient_C) * math.exp(-self.period_s / self._detach_tau_s)
            self._detached_T_C, Q = T, 0.0
        self._last = RigSample(
            t_s=self.t_s,
            T_sensor_C=self._chT(T),
            Q_W=self._chQ(Q),
            current_A=self.I,
            contact=self._contact,
            T_sink_C=x.item(0),
            force_N=self._force,
        )

    # ---- truth and introspection -----------------------------------------------------------------
    def truth(self) -> RigTruth:
        """Ground truth at the current time."""
        cfg, x = self.cfg, self.x
        n = cfg.n
        touch = self._touch
        surf = float(cfg.surf_f @ x[:n] + cfg.surf_f0) if cfg.surf_f is not None else math.nan
        q_body = float(cfg.body_q_f @ x[:n] + cfg.body_q_f0) if cfg.body_q_f is not None else 0.0
        return RigTruth(
            t_s=self.t_s,
            T_pad_C=float(x[cfg.i_p]),
            T_surface_C=surf,
            T_sensor_true_C=float(x[cfg.i_mid]),
            Q_true_W=float(cfg.q_f @ x[:n] + cfg.q_f0),
            T_sink_C=float(x[0]),
            touching=touch.body if touch else None,
            force_N=touch.force_N if touch else 0.0,
            T_contact_face_C=float(cfg.top_f @ x[:n] + cfg.top_f0),
            current_A=self.I,
            Q_into_body_W=q_body,
        )

    def pruning_report(self) -> list[str]:
        """What the compiled scene skipped, and why."""
        return list(self._pruning)

    def _stored_total(self) -> float:
        s = float(self.cfg.system.C @ self.x[: self.cfg.n])
        for b in self.bodies.values():
            if not b.attached:
                s += b.stored_J()
        return s

    def energy_balance(self) -> dict[str, float]:
        """Energy since t = 0, J: electrical input, heat out to reservoirs (ambient, blood, core), change of
        the stored heat, and the residual in − out − stored (all bodies of this rig included; detached bodies
        are first brought to the current time)."""
        for b in self.bodies.values():
            if not b.attached:
                b.advance_detached(self.t_s)
        out = float(self.x[-1]) + sum(float(b.x[-1]) for b in self.bodies.values())
        stored = self._stored_total() - self._stored0
        return {
            "E_in_J": self.E_el_J,
            "E_out_J": out,
            "dE_stored_J": stored,
            "residual_J": self.E_el_J - out - stored,
        }

    def profile(self) -> dict[str, np.ndarray]:
        """Cell temperatures of the current chain, °C, by segment name (for plots and checks)."""
        sysm = self.cfg.system
        return {sg.name: self.x[o : o + sg.n].copy() for sg, o in zip(sysm.segments, sysm.offsets)}
