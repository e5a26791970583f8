"""The defined symbols of an ELF object (dloplan.elf_symbols), on objects built by hand."""

from __future__ import annotations

import struct

from dloplan.elf_symbols import ELF_HEADER, SECTION_HEADER, SYMBOL, defined_symbols


def elf_object(symbols: list[tuple[str, int, int]]) -> bytes:
    """A minimal ELF64 object: a null section, a string table and a symbol table holding
    ``symbols`` as (name, info, section index) after the null symbol."""
    strings = b"\0" + b"".join(name.encode() + b"\0" for name, _, _ in symbols)
    offsets = [1 + sum(len(n) + 1 for n, _, _ in symbols[:k]) for k in range(len(symbols))]
    table = SYMBOL.pack(0, 0, 0, 0, 0, 0) + b"".join(
        SYMBOL.pack(offset, info, 0, section, 0, 0)
        for offset, (_, info, section) in zip(offsets, symbols, strict=True))
    strings_at = ELF_HEADER.size
    table_at = strings_at + len(strings)
    sections_at = table_at + len(table)
    sections = (SECTION_HEADER.pack(0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
                + SECTION_HEADER.pack(0, 3, 0, 0, strings_at, len(strings), 0, 0, 1, 0)
                + SECTION_HEADER.pack(0, 2, 0, 0, table_at, len(table), 1, 1, 8, SYMBOL.size))
    header = ELF_HEADER.pack(b"\x7fELF\x02\x01\x01" + bytes(9), 1, 62, 1, 0, 0, sections_at, 0,
                             ELF_HEADER.size, 0, 0, SECTION_HEADER.size, 3, 1)
    return header + strings + table + sections


GLOBAL_FUNC, LOCAL_OBJECT, WEAK_FUNC, SECTION, FILE = 0x12, 0x01, 0x22, 0x03, 0x04


def test_defined_functions_and_variables_are_named_undefined_ones_are_not():
    code = elf_object([("kernel.py", FILE, 0xFFF1), (".text", SECTION, 1),
                       ("_ZN6kernel5solveB", GLOBAL_FUNC, 1),
                       ("_ZN08NumbaEnv6kernel", WEAK_FUNC, 2),
                       (".const.kernel", LOCAL_OBJECT, 2),
                       ("NRT_MemInfo_call_dtor", GLOBAL_FUNC, 0)])  # undefined: section 0
    assert defined_symbols(code) == {"_ZN6kernel5solveB", "_ZN08NumbaEnv6kernel",
                                     ".const.kernel"}


def test_what_is_not_a_64_bit_little_endian_elf_with_a_symbol_table_gives_none():
    code = elf_object([("f", GLOBAL_FUNC, 1)])
    assert defined_symbols(b"\xcf\xfa\xed\xfe" + code[4:]) is None  # Mach-O
    assert defined_symbols(code[:4] + b"\x01" + code[5:]) is None  # 32-bit
    assert defined_symbols(code[:20]) is None  # truncated
    no_table = code[:-SECTION_HEADER.size] + SECTION_HEADER.pack(0, 1, 0, 0, 0, 0, 0, 0, 0, 0)
    assert defined_symbols(no_table) is None
    assert struct.unpack_from("<H", code, 0x3C)[0] == 3  # the test object's own three sections
