"""One bus setting for every command and node program, in python-can's own order.

:func:`resolve_bus` is the one place that decides which bus to open. Sources, first wins, key by key
(python-can's rule, ``can.util.load_config``):

1. ``--bus INTERFACE:CHANNEL`` / ``--bus socketcand://HOST:PORT/CHANNEL``, or ``-i/-c/-b`` (interface,
   channel, bitrate; as ``can.logger`` and ``can.viewer`` take them);
2. ``can.rc``, then the environment: ``CAN_INTERFACE``, ``CAN_CHANNEL``, ``CAN_BITRATE``, ``CAN_CONFIG``
   (JSON of further can.Bus arguments), each first with the suffix ``_telethermo``;
3. python-can's config file (``~/can.conf``, ``/etc/can.conf``, ``~/.can``, ``~/.canrc``; on Windows
   also ``can.ini``), section ``[telethermo]`` first, then ``[default]``;
4. the network settings file's ``[bus]`` (bus_config/network.toml) -- except that its in-process
   ``virtual`` bus, which no other process can share, gives way to a running hub or session that
   published where it listens (:mod:`telethermo.transport.published`).

The channel, host, port and options of network.toml belong to its interface: they are used only when the
resolved interface is the file's. The bitrate falls back to the file's (it is the network's).
"""

from __future__ import annotations

import configparser
import json
import os
from dataclasses import dataclass
from typing import Any, Mapping

from telethermo.transport.published import running
from telethermo.transport.bus import (
    TransportError,
    TransportSettings,
    check_interface,
    parse_bus_string,
    validate,
)
import can
import can.util

CONTEXT = (
    "telethermo"  # the section of python-can's config file, and the env suffix (CAN_INTERFACE_telethermo)
)
_FLAG = "-i/-c/-b"


@dataclass(frozen=True)
class ResolvedBus:
    """The bus to open and where that setting came from (for messages)."""

    settings: TransportSettings
    source: str


def _config_files() -> str:
    found = [p for p in can.util.CONFIG_FILES if os.path.isfile(os.path.expanduser(p))]
    return ", ".join(found) if found else "python-can config file"


def python_can_layers(
    given: Mapping[str, Any], config_path: str | None = None
) -> tuple[dict[str, Any], dict[str, str]]:
    """python-can's sources merged key by key, first wins: ``given`` (flags), ``can.rc``, the environment
    (``_telethermo`` suffix first), the config file (``[telethermo]`` first).
    Returns (config, key -> source)."""

    layers: list[tuple[str, Any]] = [
        (_FLAG, lambda: dict(given)),
        ("can.rc", lambda: dict(can.rc)),
        (f"environment (CAN_*_{CONTEXT})", lambda: can.util.load_environment_config(CONTEXT)),
        (
            "environment (CAN_INTERFACE, CAN_CHANNEL, CAN_BITRATE, CAN_CONFIG)",
            lambda: can.util.load_environment_config(),
        ),
        (
            f"[{CONTEXT}] of {config_path or _config_files()}",
            lambda: can.util.load_file_config(config_path, CONTEXT),
        ),
        (f"[default] of {config_path or _config_files()}", lambda: can.util.load_file_config(config_path)),
    ]
    config: dict[str, Any] = {}
    source: dict[str, str] = {}
    for name, load in layers:
        try:
            cfg = load()
        except json.JSONDecodeError as exc:
            raise TransportError(f"{name}: CAN_CONFIG is not JSON ({exc})") from None
        except configparser.Error as exc:  # the whole file is unreadable, whichever section was asked
            raise TransportError(
                f"{config_path or _config_files()}: not a valid python-can config file "
                f"(INI sections such as [default] or [{CONTEXT}]): {_one_line(exc)}"
            ) from None
        except Exception as exc:
            raise TransportError(f"{name}: cannot read ({_one_line(exc)})") from None
        if "bustype" in cfg:  # python-can's legacy name
            cfg.setdefault("interface", cfg["bustype"])
            del cfg["bustype"]
        for key, val in cfg.items():
            if key not in config and val is not None and val != "":
                config[key] = can.util.cast_from_string(val) if isinstance(val, str) else val
                source[key] = name
    return config, source


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())


def _int(value: Any, what: str, source: str) -> int:
    try:
        return int(value)
    except (TypeError, ValueError):
        raise TransportError(f"{source}: {what} {value!r}: expected an integer") from None


def resolve_bus(
    net,
    *,
    bus: str | None = None,
    interface: str | None = None,
    channel: str | None = None,
    bitrate: int | None = None,
    config_path: str | None = None,
    use_published: bool = True,
) -> ResolvedBus:
    """The bus to open (see the module docstring). ``net``: the loaded network settings
    (:class:`telethermo.device.netconfig.NetworkConfig`). Raises :class:`TransportError` (one line
    naming the source and what was expected)."""
    if bus and (interface or channel):
        raise TransportError("--bus and -i/-c both name the bus; give one of them")
    given = {
        k: v
        for k, v in (("interface", interface), ("channel", channel), ("bitrate", bitrate))
        if v is not None
    }
    cfg, src = python_can_layers(given, config_path)
    file_bus = net.bus
    if bus:
        rate = _int(cfg.get("bitrate", file_bus.bitrate), "bitrate", src.get("bitrate", str(net.path)))
        return ResolvedBus(parse_bus_string(bus, bitrate=rate), "--bus")
    if "interface" not in cfg:
        if use_published and file_bus.interface == "virtual" and not ({"channel", "host", "port"} & set(cfg)):
            pub = running()
            if pub is not None:
                try:
                    found = parse_bus_string(
                        pub.bus,
                        bitrate=_int(
                            cfg.get("bitrate", file_bus.bitrate), "bitrate", src.get("bitrate", str(net.path))
                        ),
                        source=str(pub.path),
                    )
                except TransportError:
                    found = None  # a damaged state file is no reason to refuse the network file's bus
                if found is not None:
                    return ResolvedBus(found, f"{pub.by} (pid {pub.pid}, {pub.path})")
        cfg["interface"], src["interface"] = file_bus.interface, str(net.path)
    where = src["interface"]
    iface = check_interface(cfg.pop("interface"), where)  # an unknown name first, before its missing channel
    options: dict[str, Any] = {}
    if iface == file_bus.interface:  # the file's channel and options belong to its interface
        options.update(file_bus.options)
        cfg.setdefault("channel", file_bus.channel)
        src.setdefault("channel", str(net.path))
        for key in ("host", "port"):
            if key in options:
                cfg.setdefault(key, options.pop(key))
                src.setdefault(key, str(net.path))
    cfg.setdefault("bitrate", file_bus.bitrate)
    src.setdefault("bitrate", str(net.path))
    chan = cfg.pop("channel", None)
    if chan is None:
        raise TransportError(
            f"{where}: interface {iface!r} but no channel; give -c CHANNEL, CAN_CHANNEL or "
            f"channel = ... in ~/.canrc"
        )
    rate = _int(cfg.pop("bitrate"), "bitrate", src["bitrate"])
    host = cfg.pop("host", None)
    port = cfg.pop("port", None)
    if port is not None:
        port = _int(port, "port", src["port"])
    options.update(cfg)  # further can.Bus arguments (tcp_tune, fd, receive_own_messages, ...)
    settings = TransportSettings(iface, str(chan), rate, host=host, port=port, options=options)
    return ResolvedBus(validate(settings, where), where)
