"""The master and slave CANopen node programs (``telethermo-master``, ``telethermo-slave``) and the
machinery they share: options, rig/parameter construction, the runtime on SYNC, peer link, recording,
process launcher and recording merge. See docs/nodes.md."""
