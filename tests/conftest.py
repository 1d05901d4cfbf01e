"""Every test's node programs and in-process nodes keep their CiA 301 parameter store (0x1010, default
``$XDG_STATE_HOME/telethermo/node<ID>.json``) in a folder of this test run, never in the user's: settings a
developer saved must not change what the tests see. Set at import, before any fixture starts a process."""
from __future__ import annotations

import os
import tempfile

os.environ["XDG_STATE_HOME"] = tempfile.mkdtemp(prefix="telethermo-test-state-")
