"""Direct-touch truth: the operator's finger touching the remote objects itself (no rigs in between).

This is what the telepresence system should make the operator feel: the SAME finger (same parameters and
initial steady state) touching the slave's objects with the slave's contact schedule (telepresence scenes), or
the materials the display renders per the master schedule's ``render`` entries (virtual scenes). Between
touches the finger is in air (its surface relaxes towards its steady state).
"""

from __future__ import annotations

import numpy as np

from telethermo.sim.bodies import FingerParams
from telethermo.sim.chain import assemble
from telethermo.sim.contact import contact_resistance_m2K_W
from telethermo.sim.expint import Modal
from telethermo.sim.pair import reversed_segment
from telethermo.sim.plant import Body, GridSettings
from telethermo.sim.scene import Scene
from telethermo.sim.tem import RigParams
from telethermo.sim.touch import BodySpec, Schedule, Touch

_SNAP_S = 1e-9


class _Pair:
    """Finger + object in contact: assembled system and probes."""

    def __init__(self, finger: Body, obj: Body, force_N: float, params: RigParams) -> None:
        A = params.area_m2
        R = contact_resistance_m2K_W(force_N, params.R_at_1N_m2K_W, params.force_exponent) / A
        # chain: finger core ... finger surface | object front ... object back (the finger seen from its back)
        fs = finger.segment
        self.system = assemble([reversed_segment(fs), obj.segment], [R], finger.back, obj.back)
        self.modal = Modal(self.system)
        self.nf, self.no = fs.n, obj.segment.n
        self.surf_f, self.surf_f0 = self.system.face_functional(0, "back")
        self.q_f, self.q_f0 = self.system.link_flux_functional(0)
        self.steps: dict[float, tuple] = {}
        self.finger, self.obj = finger, obj

    def step(self, dt: float):
        key = round(dt, 12)
        m = self.steps.get(key)
        if m is None:
            Phi, c, _, _ = self.modal.step_matrices(dt)
            m = self.steps[key] = (Phi, c)
        return m


class DirectTouch:
    """The reference: finger touching objects directly. Attributes t_s, T_contact_C, Q_finger_W, touching."""

    def __init__(
        self,
        finger_params: FingerParams,
        objects: dict[str, BodySpec],
        schedule: Schedule,
        ambient_C: float,
        params: RigParams,
        grid: GridSettings,
    ) -> None:
        self.params = params
        self.finger = Body(
            BodySpec("finger", kind="finger", finger=finger_params),
            params.area_m2,
            ambient_C,
            params.h_air_W_m2K,
            grid,
        )
        touched = schedule.bodies()
        self.objects = {
            n: Body(s, params.area_m2, ambient_C, params.h_air_W_m2K, grid)
            for n, s in objects.items()
            if n in touched
        }
        self.schedule = schedule
        self.t_s = 0.0
        self._pairs: dict[tuple, _Pair] = {}
        self._touch: Touch | None = None
        self._pair: _Pair | None = None
        self._x: np.ndarray | None = None
        self._switch()
        self._next = schedule.next_event_after(self.t_s + _SNAP_S)
        self._stored0 = self._stored()

    def _stored(self) -> float:
        s = 0.0
        if self._pair is not None:
            s += self._pair.system.stored_J(self._x)
        for b in (self.finger, *self.objects.values()):
            if self._pair is None or (b is not self._pair.finger and b is not self._pair.obj):
                b.advance_detached(self.t_s)
                s += b.stored_J()
        return s

    def energy_balance(self) -> dict[str, float]:
        """Heat out of the finger + objects to reservoirs (core, blood, air), change of stored heat, and the
        residual out + stored (no electrical input here), J, since t = 0."""
        stored = self._stored() - self._stored0
        out = sum(float(b.x[-1]) for b in (self.finger, *self.objects.values()))
        if self._pair is not None:
            out += float(self._x[-1])
        return {"E_out_J": out, "dE_stored_J": stored, "residual_J": -out - stored}

    @property
    def touching(self) -> str | None:
        return self._touch.body if self._touch else None

    def _switch(self) -> None:
        touch = self.schedule.at(self.t_s + _SNAP_S)
        if touch == self._touch:
            return
        if self._pair is not None:  # detach: give the states back
            p, x = self._pair, self._x
            self.finger.x[: p.nf] = x[: p.nf][::-1]
            self.finger.x[-1] += x[-1]
            p.obj.x[: p.no] = x[p.nf : p.nf + p.no]
            self.finger.t_s = p.obj.t_s = self.t_s
            self._pair, self._x = None, None
        self._touch = touch
        if touch is not None:
            obj = self.objects[touch.body]
            key = (touch.body, touch.force_N)
            pair = self._pairs.get(key)
            if pair is None:
                pair = self._pairs[key] = _Pair(self.finger, obj, touch.force_N, self.params)
            self.finger.advance_detached(self.t_s)
            obj.advance_detached(self.t_s)
            self._x = np.concatenate([self.finger.x[: pair.nf][::-1], obj.x[: pair.no], [0.0]])
            self._pair = pair

    def advance(self, dt_s: float) -> None:
        """Advance the reference by dt_s seconds."""
        t_end = self.t_s + dt_s
        while self.t_s < t_end - _SNAP_S:
            t_stop = self._next if self._next < t_end - _SNAP_S else t_end
            if self._pair is not None:
                Phi, c = self._pair.step(t_stop - self.t_s)
                self._x = Phi @ self._x + c
            self.t_s = t_stop
            if abs(self.t_s - self._next) <= _SNAP_S or self.t_s > self._next:
                self._switch()
                self._next = self.schedule.next_event_after(self.t_s + _SNAP_S)

    @property
    def T_contact_C(self) -> float:
        """Finger surface temperature, °C (the contact temperature while touching)."""
        if self._pair is not None:
            p = self._pair
            return float(p.surf_f @ self._x[: p.system.n] + p.surf_f0)
        self.finger.advance_detached(self.t_s)
        return self.finger.surface_C()

    @property
    def Q_finger_W(self) -> float:
        """Heat flow out of the finger into the touched object, W (0 when not touching)."""
        if self._pair is None:
            return 0.0
        p = self._pair
        return float(p.q_f @ self._x[: p.system.n] + p.q_f0)


def build_reference(scene: Scene, *, grid: GridSettings | None = None) -> DirectTouch:
    """The direct-touch truth of a scene (see module docstring)."""
    grid = grid or GridSettings.for_tolerance(scene.tolerance_C, scene.period_s)[0]
    if scene.kind == "telepresence":
        schedule = Schedule(scene.slave_contacts)
        objects = dict(scene.objects)
    else:
        touches, objects = [], dict(scene.objects)
        for t in scene.master_contacts:
            if t.render is None:
                continue
            if t.render not in objects:
                objects[t.render] = BodySpec(
                    t.render, material=t.render, thickness_m=0.02, T0_C=scene.ambient_C
                )
            touches.append(Touch(t.start_s, t.end_s, t.render, t.force_N))
        schedule = Schedule(touches)
    return DirectTouch(scene.finger, objects, schedule, scene.ambient_C, scene.rig_params, grid)
