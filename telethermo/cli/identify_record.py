"""The checks of a record taken from a live node by ``telethermo identify NODE``: a record the safety
envelope cut or a touch disturbed (the pad's contact flag, 0x2004, read while the experiment ran) is
refused before anything is fitted."""

from __future__ import annotations

import sys

import numpy as np

from telethermo.ident.plan import IdentifyPlan
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure
from telethermo.remote.identify import Stream


def contact_spans(polls: list[tuple[int, bool]]) -> list[tuple[int, int]]:
    """The (first, last) sample numbers of each run of contact among ``polls`` (sample number reached when the
    contact flag was read, flag), in the order read."""
    spans: list[tuple[int, int]] = []
    start = last = None
    for k, flag in polls + [(0, False)]:
        if flag:
            start = k if start is None else start
            last = k
        elif start is not None:
            spans.append((start, last))
            start = None
    return spans


def contact_reason(spans: list[tuple[int, int]], period_s: float) -> str:
    """``contact at 12.3-14.1 s`` (and the next runs, at most three) of the experiment: sample k at
    (k-1)·period."""

    def at(a: int, b: int) -> str:
        ta, tb = max(a - 1, 0) * period_s, max(b - 1, 0) * period_s
        return f"{ta:.1f} s" if round(ta, 1) == round(tb, 1) else f"{ta:.1f}-{tb:.1f} s"

    text = ", ".join(at(a, b) for a, b in spans[:3])
    more = f" and {len(spans) - 3} more" if len(spans) > 3 else ""
    return f"contact at {text}{more} of the experiment"


def check_record(
    stream: Stream,
    client: NodeClient,
    plan: IdentifyPlan,
    touches: list[tuple[int, bool]],
    period_s: float,
    *,
    force: bool,
) -> None:
    """Refuse a record the envelope cut or a touch disturbed (Failure): the node's safety state, the contact
    flag read throughout the experiment (``touches``) and now, and the recorded currents against the plan (a
    planned non-zero current recorded as 0 A is a cut)."""
    st, trip = int(client.get("safety_state")), int(client.get("last_trip_code"))
    planned = plan.currents()
    cut = int(np.sum((planned != 0.0) & (stream.I_A == 0.0)))
    if st == 3 or cut:
        raise Failure(
            f"{client.t.role}: the safety envelope cut the current during the experiment ({cut} samples "
            f"at 0 A instead of the plan's; safety state {st}, last trip 0x{trip:04X}); nothing fitted "
            "or loaded (see telethermo status; telethermo fault-reset once the cause is gone)"
        )
    spans = contact_spans(touches + [(plan.total, bool(int(client.get("contact"))))])
    if not spans:
        return
    reason = contact_reason(spans, period_s)
    if force:
        print(f"telethermo identify: {client.t.role}: {reason}; fitted anyway (--force)", file=sys.stderr)
        return
    raise Failure(
        f"{client.t.role}: {reason}: the fit needs a free pad; lift the probe and run again "
        "(nothing fitted or loaded)"
    )
