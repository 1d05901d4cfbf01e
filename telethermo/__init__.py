"""telethermo: bilateral thermal telepresence over CANopen.

Layers (dependencies point downwards only, see docs/architecture.md):
programs (nodes/, telethermo.cli) -> CANopen device (telethermo.device, telethermo.transport)
-> control core (telethermo.control, telethermo.ident: pure numpy/scipy) -> rig interface
(telethermo.rig) <- simulated rigs (sim/).
"""

__version__ = "0.1.0"
