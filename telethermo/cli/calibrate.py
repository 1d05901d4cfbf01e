"""``telethermo calibrate-finger``: yamamoto's per-user step (§IV-D, conclusion): the pad's
effusivity relative to THIS operator's finger (β_pad, eq. 6/7) and the finger's initial temperature.

For every touch of the pad, eq. 1 gives T_contact = (T_f0 + β_pad·T_pad0)/(1 + β_pad); two touches
at different pre-sets (or one with a known finger temperature) determine β_pad and T_f0
(:func:`telethermo.control.rendering.calibrate_finger`). The touches come either from the command
line (``--touch T_PAD0:T_CONTACT``) or from the live master (``--live``): T_pad0 is the mean pad
surface temperature (T_sensor - Q·R_sensor/2, guiatni eq. 29) in the 0.5 s before the contact
detector closes, T_contact its mean 0.1..1 s after (yamamoto's early-time window), read by SDO.
``--apply`` writes β_pad and T_f0 into the master (pad_beta, finger_T0_C), range-checked like
``telethermo set``.
"""

from __future__ import annotations

import argparse
import contextlib
import time

from telethermo.cli import common
from telethermo.cli.main import UserError
from telethermo.control.rendering import calibrate_finger
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure
from telethermo.remote.targets import lookup, resolve_node
from telethermo.remote.values import check_range, fmt

PRE_S, EARLY = 0.5, (0.1, 1.0)  # s before contact; s after contact (ETS window)


def register(subparsers) -> None:
    p = subparsers.add_parser("calibrate-finger", description=__doc__.split("\n\n")[1].replace("\n", " "))
    common.add_bus_options(p)
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument(
        "--touch",
        action="append",
        metavar="T_PAD0:T_CONTACT",
        help="one touch: pad pre-set and measured contact temperature, °C (repeat)",
    )
    src.add_argument("--live", type=int, metavar="N", help="measure N touches on the live master")
    p.add_argument(
        "--finger-temp", type=float, metavar="C", help="the finger's initial temperature if measured, °C"
    )
    p.add_argument(
        "--touch-timeout",
        type=float,
        default=60.0,
        metavar="S",
        help="--live: longest wait for each touch, s (default 60)",
    )
    p.add_argument("--poll", type=float, default=0.02, metavar="S", help="--live: SDO polling period, s")
    p.add_argument("--apply", action="store_true", help="write pad_beta and finger_T0_C into the master")
    p.add_argument("--node", default="master", help="the display node (default master)")
    p.set_defaults(func=run)


def parse_touch(text: str) -> tuple[float, float]:
    try:
        a, b = text.split(":")
        return float(a), float(b)
    except ValueError:
        raise UserError(f"--touch {text!r}: expected T_PAD0:T_CONTACT in °C, e.g. 28:30.9") from None


def measure_touch(
    read, *, timeout_s: float, poll_s: float, clock=time.monotonic, sleep=time.sleep
) -> tuple[float, float]:
    """Wait for one touch; (T_pad0, T_contact) from ``read() -> (T_sensor_C, contact)`` samples."""
    before: list[tuple[float, float]] = []
    t_end = clock() + timeout_s
    was = True  # a finger already on the pad must lift first
    while True:
        if clock() > t_end:
            raise Failure(f"no touch within {timeout_s:g} s (the contact detector did not close)")
        T, contact = read()
        now = clock()
        if not contact:
            before.append((now, T))
            before = [(t, x) for t, x in before if t >= now - PRE_S]
        elif not was and before:
            t0 = now
            break
        was = contact
        sleep(poll_s)
    after = []
    while clock() < t0 + EARLY[1]:
        T, contact = read()
        now = clock()
        if not contact:
            raise Failure("the finger left the pad within 1 s; touch and hold for at least 1 s")
        if now >= t0 + EARLY[0]:
            after.append(T)
        sleep(poll_s)
    if not after:
        raise Failure("no sample in the 0.1..1 s window; lower --poll")
    return sum(x for _, x in before) / len(before), sum(after) / len(after)


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    t = resolve_node(net, args.node)
    touches = [parse_touch(x) for x in args.touch] if args.touch else []
    apply_infos = [lookup(t, "pad_beta"), lookup(t, "finger_T0_C")] if args.apply else []
    if args.live is not None and args.live < 1:
        raise UserError(f"--live: expected a number of touches >= 1, got {args.live}")
    with contextlib.ExitStack() as stack:
        nw = stack.enter_context(common.canopen_network(args, net)) if (args.live or args.apply) else None
        node = NodeClient(nw, t, args.timeout) if nw is not None else None
        if args.live:
            ts, q, contact = (lookup(t, k) for k in ("T_sensor_C", "Q_W", "contact"))
            r_sensor = node.read(lookup(t, "R_sensor_C_per_W"))

            def read():
                # the pad surface: the thermocouple sits at the flux sensor's mid-plane, half its
                # thermal resistance below the surface (guiatni eq. 29); Q > 0 flows out of the pad
                T_mid = node.read(ts)
                return T_mid - node.read(q) * r_sensor / 2.0, bool(node.read(contact))

            for k in range(args.live):
                print(
                    f"touch {k + 1}/{args.live}: put the finger on the pad and hold it for 1 s ...",
                    flush=True,
                )
                p0, c = measure_touch(read, timeout_s=args.touch_timeout, poll_s=args.poll)
                print(f"  T_pad0 {p0:.3f} °C -> T_contact {c:.3f} °C")
                touches.append((p0, c))
        try:
            cal = calibrate_finger([p for p, _ in touches], [c for _, c in touches], args.finger_temp)
        except ValueError as exc:
            raise (Failure if args.live else UserError)(_option_names(str(exc))) from None
        print(
            f"beta_pad = {cal.beta_pad:.4f}  T_finger0 = {cal.T_finger0_C:.3f} °C  "
            f"(residual {cal.residual_C:.3f} °C, {cal.n_touches} touches)"
        )
        if args.apply:
            for info, value in zip(apply_infos, (cal.beta_pad, cal.T_finger0_C)):
                check_range(info, value)
            for info, value in zip(apply_infos, (cal.beta_pad, cal.T_finger0_C)):
                node.write(info, value)
                print(f"{t.role}: {info.key} = {fmt(node.read(info), info)}")
    return 0


def _option_names(text: str) -> str:
    """calibrate_finger's message in the words of this command: its options, not Python argument names."""
    text = text.removeprefix("calibrate_finger: ")
    for py, opt in (
        ("give T_finger0_C", "give --finger-temp"),
        ("T_finger0_C must", "--finger-temp must"),
        ("T_pad0_C and T_contact_C", "the touches (--touch T_PAD0:T_CONTACT)"),
    ):
        text = text.replace(py, opt)
    return text
