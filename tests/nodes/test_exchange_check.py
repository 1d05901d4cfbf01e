"""The real-time exchange check of the node tests (tests/nodes/exchange_check.py) tells the guarantee from
its breach: stale values in order pass, a value from a later SYNC, reordered values and a value older than
the miss limit without a peer-loss trip are named."""

from __future__ import annotations

import numpy as np

from tests.nodes.exchange_check import check_exchange

SENT = np.arange(100.0, 120.0)  # the peer sends a new value each SYNC


def test_fresh_and_stale_in_order_pass():
    got = np.r_[np.nan, SENT[:-1]]  # SYNC k uses SYNC k-1's value
    got[5:8] = SENT[3]  # three late PDOs: the value of SYNC 3 stays
    ex = check_exchange(got, SENT)
    assert not ex.unmatched and not ex.stale_untripped
    assert ex.rows == 19 and ex.fresh == 16 and ex.staleness_max == 3


def test_a_value_from_a_later_sync_or_out_of_order_is_named():
    got = np.r_[np.nan, SENT[:-1]]
    got[6] = SENT[6]  # what the peer sent at SYNC 6, used at SYNC 6: too early
    assert check_exchange(got, SENT).unmatched == [6]
    got = np.r_[np.nan, SENT[:-1]]
    got[10] = SENT[6]  # after SYNC 8's value, SYNC 6's: out of order
    assert check_exchange(got, SENT).unmatched == [10]


def test_older_than_the_miss_limit_needs_a_peer_loss_trip():
    got = np.r_[np.nan, SENT[:-1]]
    got[4:17] = SENT[2]  # 14 SYNCs behind at the end
    trips = [""] * len(SENT)
    ex = check_exchange(got, SENT, trips, miss_limit=10)
    assert ex.stale_untripped == [14, 15, 16] and ex.staleness_max == 13
    trips[13] = "peer_lost"
    assert not check_exchange(got, SENT, trips, miss_limit=10).stale_untripped
