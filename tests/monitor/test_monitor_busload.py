"""Frame length on the wire: CRC-15 and bit stuffing by ISO 11898-1."""

from hypothesis import given, strategies as st

from telethermo.monitor.busload import _crc15, frame_bits, frame_length_bits, stuff_count


def _bits_of(data: bytes) -> list[int]:
    return [(b >> (7 - i)) & 1 for b in data for i in range(8)]


def test_crc15_check_value():
    # the CRC-15/CAN catalogue check value over ASCII "123456789"
    assert _crc15(_bits_of(b"123456789")) == 0x059E


def test_stuffing_counts_the_stuff_bit_in_the_next_run():
    assert stuff_count([0] * 5) == 1
    assert stuff_count([0] * 9) == 1  # 00000 [1] 0000: the stuff bit breaks the run
    assert stuff_count([0] * 10) == 2  # 00000 [1] 00000 [1]
    assert stuff_count([0, 0, 0, 0, 0, 1, 1, 1, 1]) == 2  # 00000 [1] 1111 -> five 1s -> stuff again
    assert stuff_count([0, 1] * 20) == 0


def test_unstuffed_lengths():
    # a standard data frame is 44 + 8*DLC bits before stuffing, plus 3 intermission bits
    for n in range(9):
        bits = frame_bits(0x555, bytes([0x55] * n))
        assert len(bits) == 19 + 8 * n + 15
    assert len(frame_bits(0x1ABCDEF, b"\x00", extended=True)) == 39 + 8 + 15
    assert len(frame_bits(0x701, b"", remote=True, dlc=1)) == 19 + 15  # no data field in a remote frame


@given(st.integers(0, 0x7FF), st.binary(min_size=0, max_size=8))
def test_length_between_no_stuffing_and_worst_case(can_id, data):
    n = len(data)
    length = frame_length_bits(can_id, data)
    assert 47 + 8 * n <= length <= 47 + 8 * n + (34 + 8 * n - 1) // 4


def test_all_zero_payload_is_stuffed():
    # SYNC-like frame of zeros: the stuffed region has long runs, so stuff bits must be counted
    assert frame_length_bits(0x000, bytes(8)) > 47 + 64


def _stuff_bitwise(bits):
    """ISO 11898-1 stuffing transcribed literally: after five equal bits insert the complement,
    which itself counts towards the next run."""
    count, run, last = 0, 0, None
    for b in bits:
        if b == last:
            run += 1
        else:
            run, last = 1, b
        if run == 5:
            count += 1
            last, run = 1 - b, 1
    return count


@given(st.lists(st.integers(0, 1), max_size=160))
def test_run_based_stuff_count_equals_the_literal_rule(bits):
    assert stuff_count(bits) == _stuff_bitwise(bits)


@given(st.lists(st.integers(0, 1), min_size=1, max_size=130))
def test_table_crc_equals_bitwise_crc(bits):
    from telethermo.monitor.busload import _crc15_bitwise

    assert _crc15(bits) == _crc15_bitwise(bits)


@given(st.integers(0, 0x1FFFFFFF), st.binary(max_size=8), st.booleans(), st.booleans())
def test_frame_length_equals_literal_construction(can_id, data, extended, remote):
    from telethermo.monitor.busload import TAIL_BITS

    cid = can_id if extended else can_id & 0x7FF
    bits = frame_bits(cid, data, extended=extended, remote=remote)
    assert frame_length_bits(cid, data, extended=extended, remote=remote) == (
        len(bits) + _stuff_bitwise(bits) + TAIL_BITS
    )
