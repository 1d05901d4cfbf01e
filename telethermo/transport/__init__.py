"""Transports: python-can buses chosen by configuration (:mod:`telethermo.transport.bus`) and our
loopback-only socketcand-protocol hub for two processes on a kernel without CAN
(:mod:`telethermo.transport.hub`, command ``telethermo-hub``). See docs/nodes.md."""
