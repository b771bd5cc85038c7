/* tmp_files.h — a test's temporary folder and files, removed at the end
 * (tests include it once: its functions are static inline). */
#ifndef OHM_TESTS_TMP_FILES_H
#define OHM_TESTS_TMP_FILES_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

enum { TMP_FILES_MAX = 128 };
static char tmpdir[64];
static char *tmpfiles[TMP_FILES_MAX];
static int ntmp;

/* The folder, /tmp/<prefix>.XXXXXX; 0 on success. */
static inline int tmp_begin(const char *prefix)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/%s.XXXXXX", prefix);
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return -1;
    }
    return 0;
}

/* name's path in the folder, removed by cleanup_tmp. */
static inline const char *tmp_path(const char *name)
{
    char *p = malloc(strlen(tmpdir) + strlen(name) + 2);
    sprintf(p, "%s/%s", tmpdir, name);
    if (ntmp < TMP_FILES_MAX) tmpfiles[ntmp++] = p;
    return p;
}

static inline const char *write_tmp(const char *name, const void *data, size_t len)
{
    const char *p = tmp_path(name);
    FILE *f = fopen(p, "wb");
    if (!f || fwrite(data, 1, len, f) != len) fprintf(stderr, "cannot write %s\n", p);
    if (f) fclose(f);
    return p;
}

static inline const char *write_tmp_gz(const char *name, const void *data, size_t len)
{
    const char *p = tmp_path(name);
    gzFile f = gzopen(p, "wb");
    if (!f || gzwrite(f, data, (unsigned)len) != (int)len) fprintf(stderr, "cannot write %s\n", p);
    if (f) gzclose(f);
    return p;
}

/* path and everything under it (folders the test's writers made). */
static inline void remove_tree(const char *path)
{
    struct stat st;
    if (lstat(path, &st) != 0) return;
    DIR *d = S_ISDIR(st.st_mode) ? opendir(path) : NULL;
    if (d) {
        struct dirent *de;
        while ((de = readdir(d)) != NULL) {
            if (strcmp(de->d_name, ".") == 0 || strcmp(de->d_name, "..") == 0) continue;
            char *child = malloc(strlen(path) + strlen(de->d_name) + 2);
            if (!child) break;
            sprintf(child, "%s/%s", path, de->d_name);
            remove_tree(child);
            free(child);
        }
        closedir(d);
        rmdir(path);
    } else {
        unlink(path);
    }
}

static inline void cleanup_tmp(void)
{
    for (int i = 0; i < ntmp; ++i) free(tmpfiles[i]);
    remove_tree(tmpdir);
}

#endif
