"""A SYNC consumer that starts while the producer already runs (a restarted slave) places its SYNC numbering
on the producer's: it reads the producer's count of SYNCs (0x2713 ``sync_count``, "SYNC objects processed":
the producer processes each SYNC it sends, so its SYNC k is its (k+1)-th) by an SDO upload before its own
boot-up, and :meth:`nodes.schedule.SyncNumbering.anchor` takes the number congruent to the 1-byte counter
nearest to it. Without it a restarted slave numbered its SYNCs modulo 0x1019 (240) and its recording merged
with the master's on the wrong rows.

Limit: the producer's 0x2713 counts every SYNC it processed since its program started, so after an NMT
reset of the *producer* (its counter restarts at 1 mid-session) its count and its numbering differ and the
anchor is off by that jump modulo the counter's wrap.
"""

from __future__ import annotations

import logging

import canopen
from canopen.objectdictionary import ObjectDictionary
from canopen.sdo import SdoClient
from canopen.sdo.exceptions import SdoError

log = logging.getLogger("telethermo.node")

SYNC_COUNT_INDEX = 0x2713
#: SDO answer timeout, s, and attempts (a producer that does not answer is not running yet: nothing to anchor)
TIMEOUT_S, ATTEMPTS = 0.3, 2


def read_producer_sync_count(network: canopen.Network, producer_id: int) -> int | None:
    """The producer's 0x2713 by SDO upload (default SDO channel), or None when it does not answer."""
    client = SdoClient(0x600 + producer_id, 0x580 + producer_id, ObjectDictionary())
    client.RESPONSE_TIMEOUT = TIMEOUT_S
    client.MAX_RETRIES = ATTEMPTS - 1
    client.network = network
    network.subscribe(client.tx_cobid, client.on_response)
    try:
        data = client.upload(SYNC_COUNT_INDEX, 0)
    except (SdoError, OSError) as exc:
        log.info(
            "SYNC producer %d did not give its SYNC count (%s): numbering from the first SYNC seen",
            producer_id,
            exc,
        )
        return None
    finally:
        network.unsubscribe(client.tx_cobid, client.on_response)
    return int.from_bytes(data[:4], "little")
