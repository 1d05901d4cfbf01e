"""What a real-time exchange guarantees, checked on the recordings (docs/nodes.md, "Lockstep and real time",
"Peer loss and resume"): the value a node uses at SYNC k is one its peer *sent* at an earlier SYNC, the
values come in the order they were sent (the hub is a TCP stream: nothing reordered, nothing corrupted), and
a value older than the miss limit is used only while the node has tripped on peer loss.

How *fresh* the values are (the share of SYNCs whose peer value is the previous SYNC's) depends on the
machine's load in real time and is reported, not asserted: CiA 301 gives a synchronous TPDO no deadline
beyond "after the SYNC", and our real-time schedule does not wait for the peer (lockstep does).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Exchange:
    rows: int  # rows checked (from the first value the peer sent)
    fresh: int  # rows whose value is the previous SYNC's
    staleness_max: int  # the oldest value used, in SYNCs behind the previous one
    unmatched: list[int]  # rows whose value the peer never sent at an earlier SYNC in order (none wanted)
    stale_untripped: list[int]  # rows older than the miss limit, no peer-loss trip before them (none wanted)


def check_exchange(got, sent, trips=None, miss_limit: int = 10) -> Exchange:
    """``got[k]``: the peer value this node used at SYNC k; ``sent[j]``: what the peer sent at SYNC j (both on
    the merged SYNC axis, REAL32-rounded); ``trips[k]``: this node's new trips at k ("peer_lost|...").
    Matches each row to the earliest SYNC j >= the previous row's j with sent[j] == got[k] and j <= k-1
    (greedy earliest is the right test for a subsequence with repeated values); its age is taken from the
    youngest such j (a lower bound, so a value flagged as older than the miss limit is older)."""
    got, sent = np.asarray(got, float), np.asarray(sent, float)
    n = len(got)
    # before the first match: the stand-in values and the hub's grace for a new client
    start = next((k for k in range(1, n) if np.any(sent[:k] == got[k])), n)
    lb, fresh, worst = 0, 0, 0
    unmatched, stale_untripped = [], []
    tripped_at = [k for k in range(n) if trips is not None and "peer_lost" in str(trips[k])]
    for k in range(start, n):
        hits = np.flatnonzero(sent[lb:k] == got[k])
        if len(hits) == 0:
            unmatched.append(k)
            continue
        lb += int(hits[0])
        age = k - 1 - (lb + int(hits[-1]) - int(hits[0]))  # the youngest match (repeated values)
        fresh += age == 0
        worst = max(worst, age)
        if age > miss_limit and not any(k - age <= t <= k for t in tripped_at):
            stale_untripped.append(k)
    return Exchange(n - start, fresh, worst, unmatched, stale_untripped)
