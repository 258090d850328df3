/* File reading shared by the C programs that load FMUs (the harnesses, tests/c/fmu_run): the
 * whole file as a NUL-terminated string (malloc'ed; NULL when it cannot be read or is empty). */
#ifndef FMU_TEST_IO_H
#define FMU_TEST_IO_H

#include <stdio.h>
#include <stdlib.h>

static char *read_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        return NULL;
    }
    char *buf = NULL;
    if (fseek(f, 0, SEEK_END) == 0) {
        const long n = ftell(f);
        if (n > 0 && fseek(f, 0, SEEK_SET) == 0) {
            buf = malloc((size_t)n + 1);
            if (buf != NULL && fread(buf, 1, (size_t)n, f) == (size_t)n) {
                buf[n] = '\0';
            } else {
                free(buf);
                buf = NULL;
            }
        }
    }
    fclose(f);
    return buf;
}

#endif /* FMU_TEST_IO_H */
