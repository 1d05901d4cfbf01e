"""Fuzz cases (hypothesis): the device's frame handling, the scene loader and the model-file loader.

- **frames**: see :mod:`tests.stress.cases.fuzz_frames` (its case is listed here with the others).
- **scenes**: mutated shipped scene files (values replaced by other types, NaN/inf, huge/negative numbers,
  keys dropped, bytes flipped) through ``sim.load_scene``: either a Scene (which then builds a rig and runs
  10 steps with finite output) or ``SceneError`` naming the file and a field; nothing else.
- **model files**: mutated model JSON through ``telethermo.ident.load_model``: a TemModel or
  ``ModelFileError`` naming the file (and the field, except for whole-file errors); nothing else.
"""

from __future__ import annotations

import json
import math
import tempfile
import tomllib
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from telethermo import sim
from tests.stress.cases import toml as stress_toml
from tests.stress.cases.case import Case
from tests.stress.cases.fuzz_frames import KNOWN_FINDINGS, case_fuzz_frames
from tests.stress.cases.model import identified_model
from telethermo.ident import ModelFileError, TemModel, load_model
from telethermo.ident.modelfile import model_to_dict

HUGE_INT = 10**400
SWEEP_VALUES = (
    HUGE_INT,
    -HUGE_INT,
    math.nan,
    math.inf,
    -math.inf,
    1e308,
    -1e308,
    5e-324,
    -0.0,
    True,
    "1",
    [],
    {},
)


def _numeric_paths(doc: Any) -> list[tuple]:
    """Paths of every number (not bool) in ``doc``."""
    out = []
    for p in _paths(doc):
        v = doc
        for k in p:
            v = v[k]
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            out.append(p)
    return out


def _replaced(doc: Any, path: tuple, value: Any) -> Any:
    d = json.loads(json.dumps(doc, allow_nan=True))
    parent = d
    for k in path[:-1]:
        parent = parent[k]
    parent[path[-1]] = value
    return d


def _violation_kind(text: str) -> str:
    """Which known finding a violation is (KNOWN_FINDINGS), or "unexplained"."""
    if "OverflowError: int too large to convert to float" in text:
        return "huge_int"
    if "LinAlgError: Array must not contain infs or NaNs" in text and "current_range_A" in text:
        return "current_range"
    return "unexplained"


# ------------------------------------------------------------------------------------------------ mutations
JSONISH = st.recursive(
    st.one_of(
        st.none(),
        st.booleans(),
        st.integers(-(10**30), 10**30),
        st.integers(10**300, 10**400),
        st.floats(allow_nan=True, allow_infinity=True),
        st.text(max_size=12),
    ),
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=6,
)


def _paths(doc: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix] if prefix else []
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, prefix + (i,))
    return out


def mutate(doc: Any, data: st.DataObject, *, toml_safe: bool) -> Any:
    """Apply 1..3 random edits (replace a value, delete a key, insert a key) to a deep copy of ``doc``."""
    doc = json.loads(json.dumps(doc, allow_nan=True))
    value = JSONISH.filter(lambda v: v is not None) if toml_safe else JSONISH
    for _ in range(data.draw(st.integers(1, 3))):
        paths = _paths(doc)
        if not paths:
            break
        p = data.draw(st.sampled_from(paths))
        parent = doc
        for k in p[:-1]:
            parent = parent[k]
        op = data.draw(st.sampled_from(["replace", "replace", "delete", "insert"]))
        if op == "replace":
            parent[p[-1]] = data.draw(value)
        elif op == "delete":
            del parent[p[-1]]
        elif isinstance(parent, dict):
            parent[data.draw(st.text(min_size=1, max_size=8))] = data.draw(value)
    return doc


def _strip_none(v: Any) -> Any:
    """TOML has no null: drop None values (lists keep their other items)."""
    if isinstance(v, dict):
        return {k: _strip_none(x) for k, x in v.items() if x is not None}
    if isinstance(v, list):
        return [_strip_none(x) for x in v if x is not None]
    return v


def _bytes_mutation(text: bytes, data: st.DataObject) -> bytes:
    b = bytearray(text)
    for _ in range(data.draw(st.integers(1, 4))):
        i = data.draw(st.integers(0, max(len(b) - 1, 0)))
        op = data.draw(st.sampled_from(["flip", "delete", "insert"]))
        if op == "flip" and b:
            b[i] = data.draw(st.integers(0, 255))
        elif op == "delete" and b:
            del b[i : i + data.draw(st.integers(1, 20))]
        else:
            b[i:i] = data.draw(st.binary(min_size=1, max_size=8))
    return bytes(b)


# ------------------------------------------------------------------------------------------------ scenes
def _judge_scene(path: Path, label: str, text: bytes, stats: dict, run_steps: int) -> None:
    """Load ``text`` as a scene file: a Scene whose rigs run finite, or a SceneError naming file and field."""
    path.write_bytes(text)
    stats["examples"] += 1
    try:
        scene = sim.load_scene(path)
    except sim.SceneError as exc:
        stats["scene_errors"] += 1
        if not (exc.file == str(path) and exc.field and str(path) in str(exc) and exc.field in str(exc)):
            stats["bad"].append(f"{label}: SceneError without file/field: {exc}")
        return
    except Exception as exc:  # noqa: BLE001 - the finding
        stats["bad"].append(f"{label}: {type(exc).__name__}: {exc} <- {text[:300]!r}")
        return
    stats["accepted"] += 1
    try:
        for role in scene.rigs:
            rig = sim.build_rig(scene, role)
            for _ in range(run_steps):
                rig.apply_current(0.5)
                rig.advance(scene.period_s)
                s = rig.read()
                if not (math.isfinite(s.T_sensor_C) and math.isfinite(s.Q_W)):
                    stats["bad"].append(
                        f"{label}: accepted scene gives a non-finite sample <- {text[:300]!r}"
                    )
                    return
    except sim.SceneError:
        pass
    except Exception as exc:  # noqa: BLE001
        stats["bad"].append(
            f"{label}: accepted scene, then {type(exc).__name__} in build/run: {exc} <- {text[:300]!r}"
        )


def case_fuzz_scene_loader(max_examples: int = 200, run_steps: int = 10) -> dict:
    """Mutated scene files: a Scene or a SceneError naming file and field."""
    c = Case(
        "fuzz_scene_loader",
        "mutated shipped scenes (values of other types, NaN/inf, huge numbers, keys dropped or added, bytes "
        "flipped) through sim.load_scene: a Scene (whose rigs then build and run finite for a few steps) or "
        "a SceneError naming the file and a field; never another exception",
    )
    bases = {}
    for name in sim.shipped_scenes():
        bases[name] = tomllib.loads((sim.scene.SCENES_DIR / f"{name}.toml").read_text(encoding="utf-8"))
    stats = {"examples": 0, "accepted": 0, "scene_errors": 0, "bad": []}
    with tempfile.TemporaryDirectory() as td:
        path = Path(td) / "mutated.toml"

        def judge(label: str, text: bytes) -> None:
            _judge_scene(path, label, text, stats, run_steps)

        @settings(
            max_examples=max_examples,
            deadline=None,
            database=None,
            derandomize=True,
            suppress_health_check=list(HealthCheck),
        )
        @given(st.sampled_from(sorted(bases)), st.data())
        def structured(name, data):
            doc = _strip_none(mutate(bases[name], data, toml_safe=True))
            try:
                text = stress_toml.dumps(doc).encode("utf-8")
            except (TypeError, ValueError):
                return
            judge(f"structured:{name}", text)

        @settings(
            max_examples=max_examples // 2,
            deadline=None,
            database=None,
            derandomize=True,
            suppress_health_check=list(HealthCheck),
        )
        @given(st.sampled_from(sorted(bases)), st.data())
        def textual(name, data):
            judge(
                f"bytes:{name}", _bytes_mutation((sim.scene.SCENES_DIR / f"{name}.toml").read_bytes(), data)
            )

        structured()
        textual()
        # every number of every shipped scene replaced by each abusive value (deterministic sweep)
        for name, doc in bases.items():
            for p in _numeric_paths(doc):
                for v in SWEEP_VALUES:
                    judge(
                        f"sweep:{name}:{'.'.join(map(str, p))}={str(v)[:12]}",
                        stress_toml.dumps(_strip_none(_replaced(doc, p, v))).encode("utf-8"),
                    )
    kinds = [_violation_kind(b) for b in stats["bad"]]
    c.fig(
        examples=stats["examples"],
        accepted=stats["accepted"],
        scene_errors=stats["scene_errors"],
        violations=len(stats["bad"]),
        violations_huge_int_finding=kinds.count("huge_int"),
        violations_unexplained=kinds.count("unexplained"),
        first_violations=stats["bad"][:5],
    )
    if "huge_int" in kinds:
        c.note(KNOWN_FINDINGS["scene_huge_int"])
    c.require(
        not stats["bad"],
        f"only Scene or SceneError(file, field): {len(stats['bad'])} violations, first: {stats['bad'][:2]}",
    )
    return c.result()


# ------------------------------------------------------------------------------------------------ models
def base_model_doc() -> dict:
    """The JSON document of the model identified on the simulated rig (tests.stress.cases.model)."""

    return model_to_dict(
        TemModel(temperature=identified_model(), meta={"rig": "sim.free_pad_rig", "seed": 1})
    )


def case_fuzz_model_loader(max_examples: int = 200) -> dict:
    """Mutated model files: a TemModel or a ModelFileError naming the file."""

    c = Case(
        "fuzz_model_loader",
        "mutated model files (values of other types, NaN/Infinity, ints beyond float range, keys dropped or "
        "added, bytes flipped) through telethermo.ident.load_model: a TemModel or a ModelFileError naming "
        "the "
        "file (and the field, except for whole-file errors); never another exception",
    )
    base = base_model_doc()
    stats = {"examples": 0, "accepted": 0, "refused": 0, "bad": []}
    with tempfile.TemporaryDirectory() as td:
        path = Path(td) / "mutated.json"

        def judge(label: str, text: bytes) -> None:
            path.write_bytes(text)
            stats["examples"] += 1
            try:
                m = load_model(path)
                stats["accepted"] += 1
                if not isinstance(m, TemModel):
                    stats["bad"].append(f"{label}: returned {type(m).__name__}")
            except ModelFileError as exc:
                stats["refused"] += 1
                if not (exc.path == str(path) and str(path) in str(exc)):
                    stats["bad"].append(f"{label}: ModelFileError without the file: {exc}")
            except Exception as exc:  # noqa: BLE001 - the finding
                stats["bad"].append(f"{label}: {type(exc).__name__}: {exc} <- {text[:200]!r}")

        @settings(
            max_examples=max_examples,
            deadline=None,
            database=None,
            derandomize=True,
            suppress_health_check=list(HealthCheck),
        )
        @given(st.data())
        def structured(data):
            doc = mutate(base, data, toml_safe=False)
            try:
                text = json.dumps(doc, allow_nan=True).encode("utf-8")
            except (TypeError, ValueError, OverflowError):
                return
            judge("structured", text)

        @settings(
            max_examples=max_examples // 2,
            deadline=None,
            database=None,
            derandomize=True,
            suppress_health_check=list(HealthCheck),
        )
        @given(st.data())
        def textual(data):
            judge("bytes", _bytes_mutation(json.dumps(base).encode("utf-8"), data))

        structured()
        textual()
        # every number of the model file replaced by each abusive value (deterministic sweep, without the
        # stability check's cost for the θ entries: one value per θ entry is enough to hit the field check)
        for p in _numeric_paths(base):
            values = SWEEP_VALUES if p[:2] != ("temperature", "theta") or p[2] == 0 else (HUGE_INT,)
            for v in values:
                try:
                    text = json.dumps(_replaced(base, p, v), allow_nan=True).encode("utf-8")
                except (TypeError, ValueError, OverflowError):
                    continue
                judge(f"sweep:{'.'.join(map(str, p))}={str(v)[:12]}", text)
    kinds = [_violation_kind(b) for b in stats["bad"]]
    c.fig(
        examples=stats["examples"],
        accepted=stats["accepted"],
        refused=stats["refused"],
        violations=len(stats["bad"]),
        violations_huge_int_finding=kinds.count("huge_int"),
        violations_current_range_finding=kinds.count("current_range"),
        violations_unexplained=kinds.count("unexplained"),
        first_violations=stats["bad"][:5],
        first_unexplained=[b for b, k in zip(stats["bad"], kinds) if k == "unexplained"][:5],
    )
    if "huge_int" in kinds:
        c.note(KNOWN_FINDINGS["model_huge_int"])
    if "current_range" in kinds:
        c.note(KNOWN_FINDINGS["model_current_range"])
    c.require(
        not stats["bad"],
        f"only TemModel or ModelFileError(file): {len(stats['bad'])} violations, first: {stats['bad'][:2]}",
    )
    return c.result()


CASES = {
    "fuzz_device_frames": (case_fuzz_frames, {"max_examples": 600}, {"max_examples": 200}),
    "fuzz_scene_loader": (case_fuzz_scene_loader, {"max_examples": 600}, {"max_examples": 150}),
    "fuzz_model_loader": (case_fuzz_model_loader, {"max_examples": 400}, {"max_examples": 100}),
}
