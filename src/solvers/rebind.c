/* rebind.c — see rebind.h.  The layout read here is the ELF gABI's dynamic
 * section (DT_JMPREL, DT_PLTRELSZ, DT_RELA, DT_RELASZ, DT_SYMTAB, DT_STRTAB)
 * and the psABIs' relocation types for imported functions. */
#define _GNU_SOURCE /* dl_iterate_phdr */
#include "solvers/rebind.h"

#if defined(__linux__) && (defined(__x86_64__) || defined(__aarch64__))

#include <elf.h>
#include <link.h>
#include <stdint.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#if defined(__x86_64__)
#define JUMP_SLOT R_X86_64_JUMP_SLOT
#define GLOB_DAT R_X86_64_GLOB_DAT
#else
#define JUMP_SLOT R_AARCH64_JUMP_SLOT
#define GLOB_DAT R_AARCH64_GLOB_DAT
#endif

typedef struct request {
    const char *library;
    const ohm_rebind_target *targets;
    size_t n;
    int found; /* the library was among the loaded objects */
    int bound; /* slots that point at ours                  */
} request;

/* glibc stores the dynamic section's addresses relocated; other loaders
 * leave them as link-time addresses, which are below the load address */
static uintptr_t dyn_address(ElfW(Addr) base, ElfW(Addr) value)
{
    return value < base ? base + value : value;
}

/* write `function` into `slot`, opening a read-only (RELRO) page for it */
static int write_slot(void (**slot)(void), void (*function)(void), uintptr_t relro_begin, uintptr_t relro_end)
{
    if (*slot == function) return 1;
    uintptr_t page_size = (uintptr_t)sysconf(_SC_PAGESIZE);
    void *page = (void *)((uintptr_t)slot & ~(page_size - 1));
    int in_relro = (uintptr_t)slot >= relro_begin && (uintptr_t)slot < relro_end;
    if (in_relro && mprotect(page, page_size, PROT_READ | PROT_WRITE) != 0) return 0;
    *slot = function;
    if (in_relro) mprotect(page, page_size, PROT_READ);
    return 1;
}

/* the relocations [rela, rela + bytes): every function slot naming a target */
static int rebind_relocations(const request *q, ElfW(Addr) base, const ElfW(Rela) *rela, size_t bytes,
                              const ElfW(Sym) *symtab, const char *strtab, uintptr_t relro_begin,
                              uintptr_t relro_end)
{
    int bound = 0;
    for (size_t r = 0; r < bytes / sizeof *rela; r++) {
        unsigned type = (unsigned)ELF64_R_TYPE(rela[r].r_info);
        if (type != JUMP_SLOT && type != GLOB_DAT) continue;
        const char *name = strtab + symtab[ELF64_R_SYM(rela[r].r_info)].st_name;
        for (size_t t = 0; t < q->n; t++)
            if (strcmp(name, q->targets[t].name) == 0)
                bound += write_slot((void (**)(void))(base + rela[r].r_offset), q->targets[t].function, relro_begin,
                                    relro_end);
    }
    return bound;
}

static int visit(struct dl_phdr_info *info, size_t size, void *data)
{
    (void)size;
    request *q = data;
    if (!info->dlpi_name || !strstr(info->dlpi_name, q->library)) return 0;
    ElfW(Addr) base = info->dlpi_addr;
    const ElfW(Dyn) *dyn = NULL;
    uintptr_t relro_begin = 0, relro_end = 0;
    for (int p = 0; p < info->dlpi_phnum; p++) {
        const ElfW(Phdr) *ph = &info->dlpi_phdr[p];
        if (ph->p_type == PT_DYNAMIC) dyn = (const ElfW(Dyn) *)(base + ph->p_vaddr);
        if (ph->p_type == PT_GNU_RELRO) {
            relro_begin = base + ph->p_vaddr;
            relro_end = relro_begin + ph->p_memsz;
        }
    }
    if (!dyn) return 0;
    uintptr_t jmprel = 0, rela = 0, symtab = 0, strtab = 0;
    size_t jmprel_bytes = 0, rela_bytes = 0;
    int jmprel_is_rela = 1;
    for (; dyn->d_tag != DT_NULL; dyn++) {
        switch (dyn->d_tag) {
        case DT_JMPREL: jmprel = dyn_address(base, dyn->d_un.d_ptr); break;
        case DT_PLTRELSZ: jmprel_bytes = dyn->d_un.d_val; break;
        case DT_PLTREL: jmprel_is_rela = dyn->d_un.d_val == DT_RELA; break;
        case DT_RELA: rela = dyn_address(base, dyn->d_un.d_ptr); break;
        case DT_RELASZ: rela_bytes = dyn->d_un.d_val; break;
        case DT_SYMTAB: symtab = dyn_address(base, dyn->d_un.d_ptr); break;
        case DT_STRTAB: strtab = dyn_address(base, dyn->d_un.d_ptr); break;
        default: break;
        }
    }
    q->found = 1;
    if (!symtab || !strtab || !jmprel_is_rela) return 1;
    const ElfW(Sym) *sym = (const ElfW(Sym) *)symtab;
    const char *str = (const char *)strtab;
    if (jmprel)
        q->bound += rebind_relocations(q, base, (const ElfW(Rela) *)jmprel, jmprel_bytes, sym, str, relro_begin,
                                       relro_end);
    if (rela)
        q->bound +=
            rebind_relocations(q, base, (const ElfW(Rela) *)rela, rela_bytes, sym, str, relro_begin, relro_end);
    return 1; /* the first match only */
}

int ohm_rebind(const char *library, const ohm_rebind_target *targets, size_t n)
{
    request q = {library, targets, n, 0, 0};
    dl_iterate_phdr(visit, &q);
    return q.found ? q.bound : -1;
}

#else

int ohm_rebind(const char *library, const ohm_rebind_target *targets, size_t n)
{
    (void)library, (void)targets, (void)n;
    return -1;
}

#endif
