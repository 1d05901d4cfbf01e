"""Standard CANopen I/O modules for the rig (DESIGN.md §11, docs/hardware.md): :mod:`.module`, a simulated
CiA 401 analog I/O module (a CANopen node of our device layer with a simulated rig behind its channels);
:mod:`.scaling`, its converters' counts and volts and the simulated wiring; :mod:`.main`, the
``telethermo-iomodule`` program."""
