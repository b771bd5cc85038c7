/* ohm_oiio_load.c — ohm_oiio.h's image functions, forwarded to the module
 * libohm_oiio.so, which is opened on the first call (ohm_oiio_module.h says
 * why).  It is looked for beside the binary that holds this code (libohm.so
 * in the build tree and when installed), then by the dynamic linker's own
 * search (the executable's RUNPATH, LD_LIBRARY_PATH).  A build that links
 * ohm_oiio.cpp in (scripts/fuzz.sh) uses it directly.
 *
 * The one piece of process-wide state: the module, opened once under
 * pthread_once, as the dynamic linker's own state is process-wide. */
#define _GNU_SOURCE /* dladdr */
#include "ohm_oiio.h"
#include "ohm_oiio_module.h"

#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

/* NULL unless the module is linked into this binary */
#pragma weak ohm_oiio_module

static struct {
    pthread_once_t once;
    const ohm_oiio_api *api;
    char why[512]; /* when api is NULL: what the dynamic linker said */
} module = {PTHREAD_ONCE_INIT, NULL, ""};

static void *open_beside_this_binary(void)
{
    Dl_info info;
    if (!dladdr((void *)open_beside_this_binary, &info) || !info.dli_fname) return NULL;
    const char *slash = strrchr(info.dli_fname, '/');
    if (!slash) return NULL;
    char path[4096];
    int n = snprintf(path, sizeof path, "%.*s/%s", (int)(slash - info.dli_fname), info.dli_fname,
                     OHM_OIIO_MODULE_FILE);
    return n > 0 && (size_t)n < sizeof path ? dlopen(path, RTLD_NOW | RTLD_LOCAL) : NULL;
}

static void open_module(void)
{
    if (ohm_oiio_module) {
        module.api = ohm_oiio_module();
        return;
    }
    void *h = open_beside_this_binary();
    if (!h) h = dlopen(OHM_OIIO_MODULE_FILE, RTLD_NOW | RTLD_LOCAL);
    const char *why = h ? NULL : dlerror();
    const ohm_oiio_api *(*get)(void) = NULL;
    if (h) *(void **)&get = dlsym(h, "ohm_oiio_module"); /* POSIX's way to a function from dlsym */
    if (get) module.api = get();
    else snprintf(module.why, sizeof module.why, "%s", why ? why : "it has no ohm_oiio_module");
}

static const ohm_oiio_api *api(const char *path, ohm_error *err)
{
    pthread_once(&module.once, open_module);
    if (!module.api)
        ohm_fail(err, OHM_ERR_INTERNAL, "%s: images need ohm's OpenImageIO module %s, which cannot be loaded: %s",
                 path ? path : "(no file)", OHM_OIIO_MODULE_FILE, module.why);
    return module.api;
}

int ohm_image_format_supported(const char *path)
{
    size_t n = path ? strlen(path) : 0;
    return n >= 4 && (strcasecmp(path + n - 4, ".png") == 0 || strcasecmp(path + n - 4, ".exr") == 0);
}

int ohm_image_write_to(const char *path, const char *write_path, const float *rgb, int width, int height,
                       int channels, ohm_error *err)
{
    const ohm_oiio_api *a = api(path, err);
    return a ? a->write_to(path, write_path, rgb, width, height, channels, err) : OHM_ERR_INTERNAL;
}

int ohm_image_read_gray(const char *path, float **pixels, int *w, int *h, ohm_error *err)
{
    const ohm_oiio_api *a = api(path, err);
    return a ? a->read_gray(path, pixels, w, h, err) : OHM_ERR_INTERNAL;
}

int ohm_image_size(const char *path, int *w, int *h, int *channels, ohm_error *err)
{
    const ohm_oiio_api *a = api(path, err);
    return a ? a->size(path, w, h, channels, err) : OHM_ERR_INTERNAL;
}

int ohm_image_read_rgb(const char *path, float **pixels, int *w, int *h, ohm_error *err)
{
    const ohm_oiio_api *a = api(path, err);
    return a ? a->read_rgb(path, pixels, w, h, err) : OHM_ERR_INTERNAL;
}
