"""``telethermo dbc --out FILE`` (issue 25: "a DBC export of our PDO layout so cantools and commercial viewers
can decode our traffic"). cantools is not a dependency, so the file is checked by a structural parse of the
DBC grammar (every line one of the statements written, names C identifiers, each message's signals inside its
length and not overlapping), and by decoding frames with the parsed layout alone (little-endian bit fields,
IEEE floats where SIG_VALTYPE_ says so) against the monitor's EDS decoder on the same bytes."""

from __future__ import annotations

import random
import re
import struct

from telethermo.cli.main import EXIT_OK, EXIT_USAGE
from telethermo.cli.monitor_setup import monitor_config
from telethermo.device.netconfig import load_network
from telethermo.monitor.pdo import PdoMap, decode_pdo

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
STATEMENTS = [
    r'VERSION ""',
    r"NS_ :",
    r"BS_:",
    rf"BU_:( {IDENT})+",
    rf"BO_ (\d+) ({IDENT}): (\d) ({IDENT})",
    rf' SG_ ({IDENT}) : (\d+)\|(\d+)@1([+-]) \(1,0\) \[0\|0\] "([^"]*)" ({IDENT}(,{IDENT})*)',
    r'CM_ BO_ \d+ "[^"]*";',
    rf'CM_ SG_ \d+ {IDENT} "[^"]*";',
    rf"SIG_VALTYPE_ (\d+) ({IDENT}) : ([12]);",
    rf'VAL_ (\d+) ({IDENT})( \d+ "[^"]*")+ ;',
    r"",
]


def parse_dbc(text: str):
    """{cob: (size, sender, {signal: (start, bits, signed, unit)})}, {(cob, signal): 1|2} float types, VAL_
    tables."""
    messages, floats, tables, current = {}, {}, {}, None
    for n, line in enumerate(text.splitlines(), 1):
        assert any(re.fullmatch(s, line) for s in STATEMENTS), f"line {n} is not DBC: {line!r}"
        if m := re.fullmatch(STATEMENTS[4], line):
            current = int(m[1])
            assert current not in messages
            messages[current] = (int(m[3]), m[4], {})
        elif m := re.fullmatch(STATEMENTS[5], line):
            assert current is not None
            messages[current][2][m[1]] = (int(m[2]), int(m[3]), m[4] == "-", m[5])
        elif m := re.fullmatch(STATEMENTS[8], line):
            floats[(int(m[1]), m[2])] = int(m[3])
        elif m := re.fullmatch(STATEMENTS[9], line):
            tables[(int(m[1]), m[2])] = dict((int(v), t) for v, t in re.findall(r' (\d+) "([^"]*)"', line))
    return messages, floats, tables


def decode(layout, floats, cob: int, data: bytes) -> dict[str, float]:
    raw = int.from_bytes(data, "little")
    out = {}
    for name, (start, bits, signed, _) in layout.items():
        v = (raw >> start) & ((1 << bits) - 1)
        if (cob, name) in floats:
            out[name] = struct.unpack("<f" if bits == 32 else "<d", v.to_bytes(bits // 8, "little"))[0]
        else:
            out[name] = v - (1 << bits) if signed and v >> (bits - 1) else v
    return out


def test_the_dbc_parses_back_and_decodes_as_the_eds_does(cli, tmp_path):
    out = tmp_path / "telethermo.dbc"
    code, stdout, err = cli("dbc", "--out", str(out))
    assert code == EXIT_OK, err
    messages, floats, tables = parse_dbc(out.read_text())
    cfg = monitor_config(load_network())
    pmap = PdoMap(ods={k: n.od for k, n in cfg.nodes.items()})
    tpdos = {cob: p for cob, p in pmap.table.items() if p.direction == "TPDO" and p.valid}
    assert (
        set(messages) == set(tpdos)
        and stdout == f"{out}: {len(tpdos)} messages, {sum(len(m[2]) for m in messages.values())} signals\n"
    )
    rng = random.Random(25)
    for cob, pdef in tpdos.items():
        size, sender, layout = messages[cob]
        assert sender == cfg.nodes[pdef.node].name and size * 8 >= pdef.length_bits
        bits = sorted((s, s + b) for s, b, _, _ in layout.values())
        assert all(a[1] <= b[0] for a, b in zip(bits, bits[1:])) and bits[-1][1] <= size * 8  # no overlap
        assert {e.name: e.unit for e in pdef.entries} == {k: v[3] for k, v in layout.items()}
        for _ in range(20):
            data = bytearray(rng.randbytes(size))
            for name, (start, nbits, _, _) in layout.items():
                if (cob, name) in floats:  # a finite float in each REAL32 field
                    raw = int.from_bytes(data, "little") & ~(((1 << nbits) - 1) << start)
                    f = struct.unpack("<I", struct.pack("<f", rng.uniform(-500, 500)))[0]
                    data = bytearray((raw | f << start).to_bytes(size, "little"))
            ours = {v.name: v.value for v in decode_pdo(pdef, bytes(data))[0]}
            theirs = decode(layout, floats, cob, bytes(data))
            for name, v in ours.items():
                # BOOLEAN: any non-zero byte is true
                got = bool(theirs[name]) if isinstance(v, bool) else theirs[name]
                assert got == v, (hex(cob), name)
    material = tables[(0x682, "identified_material")]
    assert material[0] == "none" and material[7] == "glass" and material[255] == "unknown"


def test_dbc_refuses_a_wrong_name_and_an_existing_file(cli, tmp_path):
    code, _, err = cli("dbc", "--out", str(tmp_path / "x.txt"))
    assert code == EXIT_USAGE
    assert err == f"telethermo dbc: error: --out {tmp_path / 'x.txt'}: expected a .dbc file name\n"
    (tmp_path / "x.dbc").write_text("mine")
    code, _, err = cli("dbc", "--out", str(tmp_path / "x.dbc"))
    assert code == EXIT_USAGE and "already exists; give another name, or --force to replace" in err
    assert (tmp_path / "x.dbc").read_text() == "mine"
