"""The CANopen bus monitor: decode frames (CiA 301) into per-node state, bus statistics and events.

Modules, one concept each: :mod:`telethermo.cia301` (tables: abort codes, EMCY codes, NMT states),
:mod:`.decoder` (one frame → kind, node, fields), :mod:`.sdo` (one SDO state machine per node),
:mod:`.pdo` (PDO mapping from the EDS and from remapping seen on the bus), :mod:`.busload` (frame
length on the wire with bit stuffing), :mod:`.events` (event log with severity), :mod:`.state`
(:class:`~telethermo.monitor.state.Monitor`: frames in, state and events out; no clock, no I/O),
:mod:`.records` (its settings and the per-node, per-PDO, SDO and bus records it keeps),
:mod:`.frames` (the raw frame list per COB-ID and the frame history), :mod:`.health` (the CAN
controller's state from error frames and python-can's ``bus.state``), :mod:`.hints` (incident
"check first" advice), :mod:`.replay` (log files, record's CSV, pacing, live source), :mod:`.record`
(log + decoded CSV), :mod:`.view` (screen renderer, keys and curses view), :mod:`.pages` (the
view's other pages: raw list, frame and event logs with scrollback, hints, temperatures, help),
:mod:`.run` (the view and line/JSON loops, the bus-state poller).
"""
