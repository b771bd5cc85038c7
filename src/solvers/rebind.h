/* rebind.h — point one shared library's calls of named functions at ours.
 *
 * Why: factor_watch.c defines dsyrk_, dgemm_, dpotrf_ and dtrsm_ in libohm
 * so that CHOLMOD's supernodal factorization reports progress and can be
 * cancelled.  The dynamic linker binds CHOLMOD's calls to the first
 * definition in the process's global scope, which is libohm's when libohm is
 * linked into the program (the ohm command, a C program, Python's ctypes),
 * but the host's own LAPACK when the host program links one: Blender does,
 * and there a factorization of 10^5-10^6 cells ran for seconds past Cancel.
 *
 * How: the library's calls go through its global offset table, one slot per
 * imported function, named by its PLT relocations (DT_JMPREL; DT_RELA's
 * GLOB_DAT entries where it was built with -fno-plt).  ohm_rebind finds the
 * library among the loaded objects (dl_iterate_phdr), and writes our
 * function's address into each slot whose relocation names one of ours:
 * from then on that library alone calls ours, whatever else the process
 * loaded.  A slot in the read-only part (RELRO) is made writable for the
 * write and read-only again.  Linux/ELF on x86-64 and AArch64; elsewhere it
 * does nothing and says so (the caller keeps its fallback). */
#ifndef OHM_REBIND_H
#define OHM_REBIND_H

#include <stddef.h>

typedef struct ohm_rebind_target {
    const char *name;       /* the symbol as the library imports it: "dpotrf_" */
    void (*function)(void); /* ours (any function type: ISO C's generic one)    */
} ohm_rebind_target;

/* Points every call that the first loaded object whose file name contains
 * `library` makes to targets[i].name at targets[i].function.  Returns the
 * number of slots that now point at ours (already or newly), or -1 when no
 * such library is loaded or this platform is not supported. */
int ohm_rebind(const char *library, const ohm_rebind_target *targets, size_t n);

#endif
