"""Cheaper loading of numba's cached kernels: the bitcode for linking is parsed on first use.

A kernel compiled with ``cache=True`` is stored as machine code (an object file) plus the LLVM
bitcode of its whole module (the kernel and every helper inlined or linked into it), kept only so
that a *later compilation* can link the kernel in. numba 0.62 parses that bitcode when it loads the
kernel, and walks every function and global in it to note which symbols are defined: measured on the
first ``tessellate_shell`` of occt__screw.step, 53 ms of parsing and 22 ms of walking (with one
llvmlite call and two numba events per function or global) out of 93 ms for loading 18 kernels,
and the cost grows with the bitcode (550 kB for ``discretize_chunks_kernel``: 25 ms). Running a
loaded kernel needs only the object file.

`install` replaces numba's loading of such a library (``CPUCodeLibrary._unserialize``, kind
``"object"``) by the same steps minus the parse: the object file is handed to the JIT exactly as
numba does (same machine code, so results are bit-identical), the symbols it defines are read from
the object file's ELF symbol table, and the bitcode is parsed (and its symbols noted, as numba would
have) only if a new compilation asks to link the library (``_get_module_for_linking``). Object files
that are not ELF (macOS, Windows), another numba version, or ``TRIMSURF_NUMBA_LAZY_BITCODE=0`` keep
numba's own loading. Measured over the 28 kernels a ``trimsurf tessellate`` called before main e036f2c
added four: 120 ms -> 25 ms of CPU, from about 1.0 ms + 40 us per kB of bitcode per kernel to 0.6 ms +
8 us per kB of machine code.

`load_cached` loads a dispatcher's cached specializations ahead of its first call (never compiling);
the ``trimsurf tessellate`` command uses it to load its kernels while the reader reads (`trimsurf.cli._preload`).
"""

from __future__ import annotations

import os
import struct

__all__ = ["install", "installed", "elf_defined_symbols", "load_cached"]

#: the numba versions whose ``CPUCodeLibrary._unserialize`` this module re-implements (read and checked)
NUMBA_VERSIONS = ("0.62.1",)

_installed = False


def installed() -> bool:
    """True if `install` replaced numba's loading in this process."""
    return _installed


def elf_defined_symbols(data: bytes) -> set[str] | None:
    """Names of the symbols an ELF64 little-endian object file defines (section index not UNDEF; not
    the section and file-name entries).

    None if `data` is not such a file (the caller then keeps numba's own loading).
    """
    if len(data) < 64 or data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        return None
    shoff, = struct.unpack_from("<Q", data, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", data, 0x3A)
    if shentsize != 64 or shoff + 64 * shnum > len(data):
        return None
    names: set[str] = set()
    found = False
    for i in range(shnum):
        sh_type, = struct.unpack_from("<I", data, shoff + 64 * i + 4)
        if sh_type != 2:        # SHT_SYMTAB
            continue
        found = True
        off, size, link, _info, _align, entsize = struct.unpack_from("<QQIIQQ", data, shoff + 64 * i + 24)
        str_off, str_size = struct.unpack_from("<QQ", data, shoff + 64 * link + 24)
        strtab = data[str_off:str_off + str_size]
        for s in range(off + entsize, off + size, entsize):    # entry 0 is the null symbol
            st_name, st_info, _st_other, st_shndx = struct.unpack_from("<IBBH", data, s)
            if st_shndx != 0 and st_name and (st_info & 0xF) not in (3, 4):     # not STT_SECTION, STT_FILE
                names.add(strtab[st_name:strtab.index(b"\0", st_name)].decode())
    return names if found else None


def install() -> bool:
    """Make numba parse a cached kernel's linking bitcode on first use instead of at load time.

    Idempotent; returns True if the lazy loading is active (see the module notes for when it is not).
    """
    global _installed
    if _installed:
        return True
    if os.environ.get("TRIMSURF_NUMBA_LAZY_BITCODE", "1").strip() == "0":
        return False
    import numba
    from numba.core import codegen

    lib_cls = codegen.JITCodeLibrary
    if numba.__version__ not in NUMBA_VERSIONS or not all(
            hasattr(lib_cls, a) for a in ("_unserialize", "_get_module_for_linking", "enable_object_caching",
                                          "_set_compiled_object", "_finalize_final_module")):
        return False
    numba_unserialize = lib_cls._unserialize.__func__
    numba_module_for_linking = lib_cls._get_module_for_linking

    def _unserialize(cls, cg, state):
        name, kind, data = state
        if kind != "object" or not issubclass(cls, lib_cls):
            return numba_unserialize(cls, cg, state)
        object_code, shared_bitcode = data
        symbols = elf_defined_symbols(object_code)
        if symbols is None:
            return numba_unserialize(cls, cg, state)
        # numba's steps (codegen.CPUCodeLibrary._unserialize, kind "object") without parse_bitcode
        self = cg.create_library(name)
        assert isinstance(self, cls)
        self.enable_object_caching()
        self._set_compiled_object(object_code)
        self._trimsurf_bitcode = shared_bitcode
        self._finalize_final_module()
        cg._engine._defined_symbols |= symbols
        return self

    def _get_module_for_linking(self):
        bitcode = self.__dict__.pop("_trimsurf_bitcode", None)
        if bitcode is not None:     # numba's deferred steps: the parse, and the symbols noted from it
            from llvmlite import binding as ll

            self._shared_module = ll.parse_bitcode(bitcode)
            self._codegen._engine._load_defined_symbols(self._shared_module)
        return numba_module_for_linking(self)

    lib_cls._unserialize = classmethod(_unserialize)
    lib_cls._get_module_for_linking = _get_module_for_linking
    _installed = True
    return True


def load_cached(dispatcher) -> int:
    """Load every specialization of a numba `dispatcher` that numba's cache holds, without compiling.

    What a call with those argument types would load (``Dispatcher.compile``: the cache lookup, then
    ``insert_user_function`` and ``add_overload``), done ahead of the call; a specialization not in the
    cache, or cached for another CPU or another version of the function's code, is left alone (the call
    compiles it, as before). Returns the number loaded.
    """
    from numba.core import sigutils
    from numba.core.compiler_lock import global_compiler_lock

    cache = getattr(dispatcher, "_cache", None)
    cache_file = getattr(cache, "_cache_file", None)
    if cache_file is None:          # not cache=True (numba's NullCache)
        return 0
    n = 0
    with global_compiler_lock:
        ctx = dispatcher.targetctx
        ctx.refresh()
        codegen = ctx.codegen()
        for key in cache_file._load_index():
            sig = key[0]
            if key != cache._index_key(sig, codegen):
                continue
            args, _ = sigutils.normalize_signature(sig)
            if tuple(args) in dispatcher.overloads:
                continue
            cres = cache.load_overload(sig, ctx)
            if cres is None or cres.objectmode:
                continue
            ctx.insert_user_function(cres.entry_point, cres.fndesc, [cres.library])
            dispatcher.add_overload(cres)
            dispatcher._cache_hits[sig] += 1
            n += 1
    return n
