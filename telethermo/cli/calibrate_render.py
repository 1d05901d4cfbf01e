"""``telethermo calibrate-render-table``: this operator's rendering table, measured as yamamoto measured
Table 1.

β of eq. 1 is relative to a finger, and the shipped table is another subject's (or b/b_epidermis). The
operator touches each reference sample directly, with a thin thermocouple between finger and sample (or a
radiation thermometer on the finger before the touch and the sample's surface after it), and gives, per
touch, MATERIAL:T_FINGER0:T_OBJECT:T_CONTACT in °C: the finger just before the touch, the sample, and the mean
contact temperature 0.1–1 s into the touch. β = (T_finger0 − T_contact)/(T_contact − T_object) per touch,
averaged per material; two touches per material, one colder and one warmer than the finger, cancel most of
the finger's own asymmetry (on the simulated finger the two differ by 3–8 %). The table is written to --out
(atomically) with the shipped table's materials and order, so material codes keep their meaning; render with
it by ``telethermo mode render MATERIAL --table FILE``.
"""

from __future__ import annotations

import argparse
from collections import defaultdict

from telethermo.atomic import write_text_atomic
from telethermo.cli.main import UserError
from telethermo.control.render_table import load_render_table, user_render_table_text
from telethermo.control.rendering import relative_effusivity_from_contact


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate-render-table", description=__doc__.split("\n\n")[1].replace("\n", " ")
    )
    p.add_argument(
        "--touch",
        action="append",
        required=True,
        metavar="MATERIAL:T_FINGER0:T_OBJECT:T_CONTACT",
        help="one direct touch of a reference sample, temperatures in °C (repeat; >= 1 per material)",
    )
    p.add_argument("--out", required=True, metavar="TOML", help="the operator's rendering table to write")
    p.add_argument("--base", metavar="TOML", help="the table to start from (default: the shipped one)")
    p.set_defaults(func=run)


def parse_touch(text: str, known: dict[str, float]) -> tuple[str, float]:
    """(material, β) of one ``--touch`` (UserError naming the option and what was expected)."""
    parts = text.split(":")
    try:
        if len(parts) != 4:
            raise ValueError
        name, (T_f, T_o, T_c) = parts[0].strip().lower(), (float(x) for x in parts[1:])
    except ValueError:
        raise UserError(
            f"--touch {text!r}: expected MATERIAL:T_FINGER0:T_OBJECT:T_CONTACT in °C, e.g. wood:33.9:20:27.4"
        ) from None
    if name not in known:
        raise UserError(f"--touch {text!r}: unknown material {name!r} (the table has {', '.join(known)})")
    try:
        return name, relative_effusivity_from_contact(T_f, T_o, T_c)
    except ValueError as exc:
        raise UserError(f"--touch {text!r}: {exc}") from None


def run(args: argparse.Namespace) -> int:
    try:
        known = load_render_table(args.base)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    per: dict[str, list[float]] = defaultdict(list)
    for text in args.touch:
        name, beta = parse_touch(text, known)
        per[name].append(beta)
    betas = {name: sum(v) / len(v) for name, v in per.items()}
    how = "telethermo calibrate-render-table, " + ", ".join(f"{n} x{len(v)}" for n, v in per.items())
    write_text_atomic(args.out, user_render_table_text(betas, how, args.base))
    for name, beta in betas.items():
        spread = max(per[name]) - min(per[name])
        n = len(per[name])
        print(f"{name:16s} beta {beta:.4g} (was {known[name]:.4g}; {n} touches, spread {spread:.3g})")
    print(f"wrote {args.out}: render with `telethermo mode render MATERIAL --table {args.out}`")
    return 0
