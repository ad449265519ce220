"""pythonfmu 0.7.0: a process that instantiated a pythonfmu FMU reads freed memory at exit.

The library keeps its interpreter holder in a static ``std::shared_ptr`` (``pyState``,
src/pythonfmu/PySlaveInstance.cpp). At exit the C++ runtime destroys it (an exit handler); then
the library's ``__attribute__((destructor))`` (``onLibraryUnload``) assigns ``nullptr`` to the
destroyed pointer, which releases its freed control block again: valgrind reports "Invalid read
of size 4 ... finalizePythonInterpreter ... 8 bytes inside a block of size 128 free'd". The
write that follows corrupts the heap in some runs: "corrupted double-linked list", SIGABRT
(6 of 16 runs of a process that loaded the 16 pythonfmu FMUs of satfmu). ``fmi2FreeInstance``
and unloading the library do not avoid it: the library defines STB_GNU_UNIQUE symbols, so glibc
marks it NODELETE and ``dlclose`` never runs its destructors early.

Usage: ``valgrind python scripts/upstream/exit_without_reset.py [FMU]`` (one invalid read in
``finalizePythonInterpreter`` expected today), or plainly, repeated, with the 16 FMUs.
"""
import sys

from common import Fmu, report

fmus = [Fmu([path]) for path in sys.argv[1:]] or [Fmu([])]
for fmu in fmus:
    fmu.slave.fmi2FreeInstance(fmu.ready())
    fmu.slave.freeLibrary()
report(f"{len(fmus)} FMU(s) instantiated, freed and unloaded; exiting")
