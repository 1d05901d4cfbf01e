"""The client side of a remote CANopen node: what the operator CLI, ``identify`` and the monitor use to
talk to (or name) a node on the bus. A layer below the programs (``telethermo/cli``, ``telethermo/monitor``)
and above the device and transport layers (it uses canopen's ``RemoteNode`` and the EDS reader of
``telethermo.device``).

- :mod:`~telethermo.remote.errors`: the two kinds of failure (operator input, exit 2; node, exit 1).
- :mod:`~telethermo.remote.targets`: the nodes of the network file by name or node-ID, their EDS.
- :mod:`~telethermo.remote.codec`: EDS data types <-> bytes.
- :mod:`~telethermo.remote.values`: parsing an operator's value, range checks, formatting with units.
- :mod:`~telethermo.remote.client`: :class:`~telethermo.remote.client.NodeClient`, SDO by EDS name.
- :mod:`~telethermo.remote.heartbeat`: every heartbeat and boot-up on the bus.
- :mod:`~telethermo.remote.pdo`: saving, remapping and restoring a remote node's TPDO.
- :mod:`~telethermo.remote.identify`: a node's identification service and model objects, client side.

This ``__init__`` imports nothing: ``telethermo --help`` imports :mod:`~telethermo.remote.errors` only.
"""
