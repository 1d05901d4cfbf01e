"""``telethermo status``: what each node is doing, read by SDO (and its NMT state from the heartbeat).

Each value is shown as ``get`` shows it (:mod:`telethermo.remote.values`): the unit, names for
enumerations (``1 (telepresence)``), hex with the meaning for bit fields and EMCY codes."""

from __future__ import annotations

import argparse
import json
import math
import time

from canopen.sdo import SdoAbortedError, SdoCommunicationError

from telethermo.cli import common
from telethermo.control.render_table import material_name
from telethermo.control.safety_limits import limits_from_mask
from telethermo.remote import values
from telethermo.remote.client import NodeClient, remote_node
from telethermo.remote.errors import Failure, UserError
from telethermo.remote.heartbeat import heartbeat_wait_s, watch_heartbeats
from telethermo.remote.targets import eds_info, lookup, node_targets, resolve_node

#: (label, EDS key) read from each node, in display order
FIELDS = (
    ("mode", "mode"),
    ("T_sensor", "T_sensor_C"),
    ("T_sink", "T_sink_C"),
    ("estimate", "estimate_C"),
    ("T_pred", "T_pred_C"),
    ("T_cmd", "T_cmd_C"),
    ("peer estimate", "peer_estimate_C"),
    ("flux", "Q_W"),
    ("peer flux", "peer_Q_W"),
    ("current", "current_A"),
    ("contact", "contact"),
    ("safety", "safety_state"),
    ("limits", "limits_active"),
    ("last trip", "last_trip_code"),
    ("latched trips", "active_trips"),
    ("cycles", "cycle_counter"),
    ("late cycles", "late_cycles"),
    ("input timeouts", "input_timeouts"),
    ("module restarts", "module_restarts"),
    ("lockstep", "lockstep"),
    ("peer alive", "peer_alive"),
    ("link fallback", "link_fallback_active"),
    ("error register", "0x1001"),
    ("last EMCY", "0x1003sub1"),
    ("model", "model_status"),
    ("model CRC-32", "model_crc32"),
    ("identification", "ident_state"),
    ("material (id)", "identified_material"),
    ("material stage", "identified_stage"),
    ("posterior (id)", "identified_posterior"),
    ("first answer", "identified_early_material"),
    ("first posterior", "identified_early_posterior"),
    ("material beta", "identified_beta"),
    ("material touches", "identified_touches"),
    ("stored", "store_state"),
    ("stored at", "store_saved_unix_s"),
    ("store file", "store_file"),
)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "status",
        description="Read each node's state by SDO: mode, temperatures, estimates, heat "
        "flux, current, safety state, late cycles, last EMCY; NMT state from "
        "its heartbeat. Exit 1 if a node does not answer.",
    )
    common.add_bus_options(p)
    p.add_argument("nodes", nargs="*", metavar="NODE", help="master, slave or a node-ID (default: all)")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(func=run)


def pretty(value, info, eds) -> str:
    """A value as ``get`` prints it (:func:`telethermo.remote.values.fmt`); '-' for one the node refused; an
    identified material's code (the answer so far and the touch's first one) with its name in the rendering
    table (1-based, as material_code)."""
    if value is None:
        return "-"
    text = values.fmt(value, info, eds)
    if info.key in ("identified_material", "identified_early_material"):
        text += f" ({material_name(value)})"
    if info.key == "limits_active":  # which limit acted: a target beyond the clamps shows setpoint_clamp
        text = ", ".join(limits_from_mask(int(value))) or "none"
    if info.key == "store_saved_unix_s":  # seconds since 1970 as a person reads them
        text = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(value)) if value else "-"
    return text


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    targets = [resolve_node(net, n) for n in args.nodes] if args.nodes else node_targets(net)
    out, silent = [], []
    with common.canopen_network(args, net) as nw:
        hb = watch_heartbeats(nw)
        for t in targets:
            node = NodeClient(nw, t, args.timeout)
            row = {"node_id": t.node_id, "role": t.role, "values": {}, "units": {}, "error": None}
            for label, key in FIELDS:
                try:
                    info = lookup(t, key)
                except UserError:
                    continue  # this node's EDS lacks the object
                try:
                    v = node.read(info)
                except Failure as exc:
                    if "did not answer" in str(exc):
                        row["error"] = str(exc)
                        silent.append(t.role)
                        break
                    v = None  # refused (e.g. 0x1003 empty): show '-'
                row["values"][info.key] = v
                row["units"][info.key] = info.unit
                row.setdefault("text", {})[label] = pretty(v, info, eds_info(t))
            if not row["values"] and row["error"] is None:  # no EDS: is the device there at all?
                try:
                    dt = int.from_bytes(
                        remote_node(nw, t.node_id, args.timeout).sdo.upload(0x1000, 0), "little"
                    )
                    row["values"]["Device type"] = dt
                    row.setdefault("text", {})["device type"] = f"0x{dt:08X} (0x1000; no EDS: raw SDO only)"
                except SdoAbortedError as exc:  # it answered
                    row["values"]["Device type"] = None
                    row.setdefault("text", {})["device type"] = f"- (0x1000: {exc})"
                except SdoCommunicationError as exc:
                    silent.append(t.role)
                    row["error"] = (
                        f"{t.role} (node {t.node_id}) did not answer reading 0x1000 device type ({exc})"
                    )
            out.append(row)
        hb.wait_for(lambda: all(r["node_id"] in hb.last for r in out), heartbeat_wait_s(net))
        for r in out:
            r["nmt_state"] = hb.state_name(r["node_id"])
            if r["error"] and r["nmt_state"] == "STOPPED":
                r["error"] += " (a STOPPED node answers no SDO: telethermo nmt preop|start first)"
    if args.json:
        clean = [{k: v for k, v in r.items() if k != "text"} for r in out]
        for r in clean:
            # JSON has no NaN or infinity: a value the node reports as one is null (as is a refused read)
            r["values"] = {
                k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in r["values"].items()
            }
        print(json.dumps({"nodes": clean}, indent=2, allow_nan=False))
    else:
        for r in out:
            print(f"{r['role']} (node {r['node_id']}): NMT {r['nmt_state']}")
            if r["error"]:
                print(f"  {r['error']}")
            for label, text in r.get("text", {}).items():
                print(f"  {label:15s} {text}")
    if silent:
        rb = common.resolved_bus(args, net)  # which bus was asked: a node on another one answers nothing
        raise Failure(
            f"no SDO answer from {', '.join(silent)} on {rb.settings.describe()} (from {rb.source}); "
            "are they on this bus (--bus, -i/-c)?"
        )
    return 0
