"""The symbols an ELF object file defines, read from its symbol table.

numba keeps a cached kernel as the machine code of its library (a relocatable ELF object on
Linux) and the library's LLVM bitcode; :mod:`dloplan.jit` names the library's defined symbols
from the object's symbol table instead of parsing the bitcode for them. Only the 64-bit
little-endian ELF numba writes on x86-64 and AArch64 Linux is read; anything else gives None
(the caller then does as numba does).
"""

from __future__ import annotations

import struct

ELF_HEADER = struct.Struct("<16sHHIQQQIHHHHHH")
"""An ELF64 file header (``Elf64_Ehdr``, little-endian): ident, type, machine, version, entry,
program and section header offsets, flags, header size, program header entry size and count,
section header entry size and count, index of the section names."""

SECTION_HEADER = struct.Struct("<IIQQQQIIQQ")
"""An ELF64 section header (``Elf64_Shdr``): name, type, flags, address, offset, size, link,
info, alignment, entry size."""

SYMBOL = struct.Struct("<IBBHQQ")
"""An ELF64 symbol (``Elf64_Sym``): name offset, info (binding and type), other, section
index, value, size."""

ELF64_LITTLE = b"\x7fELF\x02\x01"
"""The first bytes of a 64-bit little-endian ELF file (magic, class 2, data 1)."""

SHT_SYMTAB = 2
"""The section type of a symbol table."""

SHN_UNDEF = 0
"""The section index of an undefined (external) symbol."""

STT_SECTION, STT_FILE = 3, 4
"""The symbol types that name a section or the source file, not code or data."""


def defined_symbols(object_code: bytes) -> set[str] | None:
    """The names of the functions and variables an ELF object defines.

    Parameters
    ----------
    object_code : bytes
        A relocatable object file, as numba caches a compiled library.

    Returns
    -------
    set of str or None
        Every named symbol of the object's symbol table that is defined in one of its sections
        (local, global and weak alike; section and file symbols left out): the same names as
        the non-declarations of the LLVM module it was compiled from. None when the bytes are
        not a 64-bit little-endian ELF file with a symbol table.
    """
    if not object_code.startswith(ELF64_LITTLE) or len(object_code) < ELF_HEADER.size:
        return None
    header = ELF_HEADER.unpack_from(object_code)
    offset, entry_size, count = header[6], header[11], header[12]
    if entry_size != SECTION_HEADER.size or offset + count * entry_size > len(object_code):
        return None
    sections = [SECTION_HEADER.unpack_from(object_code, offset + k * entry_size)
                for k in range(count)]
    tables = [s for s in sections if s[1] == SHT_SYMTAB]
    if not tables:
        return None
    names: set[str] = set()
    for table in tables:
        start, size, strings = table[4], table[5], sections[table[6]][4]
        for name, info, _, section, _, _ in SYMBOL.iter_unpack(
                object_code[start:start + size - size % SYMBOL.size]):
            if name and section != SHN_UNDEF and info & 0xF not in (STT_SECTION, STT_FILE):
                first = strings + name
                names.add(object_code[first:object_code.index(b"\0", first)].decode())
    return names
