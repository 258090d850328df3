/*
 * Build-time tool: print the descriptive files of the FMU of the model linked into this
 * executable, from its variable table.
 *
 * Usage: <model>_xmlgen --fmi 2|3 [--xml OUT] [--build-description OUT]
 *                       [--doc OUT [--equations FRAGMENT.html] --conventions FRAGMENT.html
 *                        --platforms A,B,...]
 *                       [--terminals OUT] [--ls-bus-manifest OUT]   (a model with a CAN terminal)
 *                       [SOURCE...]
 * SOURCE... are the compile units shipped in the FMU's sources/ (names only); --platforms names
 * the binaries/ folders the build packs into the archive (the documentation lists them); without
 * --equations (a model folder without equations.html) the documentation points to the manual.
 */
#include "fmu_xml.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The whole file as a NUL-terminated string, or NULL (message on stderr). */
static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    char *buf = NULL;
    long n = -1;
    if (f != NULL && fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) >= 0 &&
        fseek(f, 0, SEEK_SET) == 0 && (buf = malloc((size_t)n + 1)) != NULL &&
        fread(buf, 1, (size_t)n, f) == (size_t)n) {
        buf[n] = '\0';
    } else {
        perror(path);
        free(buf);
        buf = NULL;
    }
    if (f != NULL) {
        fclose(f);
    }
    return buf;
}

typedef enum { OUT_XML, OUT_BUILD, OUT_DOC, OUT_TERMINALS, OUT_LS_MANIFEST } out_kind;

static int write_one(out_kind kind, const char *path, int fmi, fmu_sources src, const char *eq,
                     const char *conv, const char *platforms)
{
    FILE *f = fopen(path, "w");
    if (f == NULL) {
        perror(path);
        return 1;
    }
    int rc = 1;
    switch (kind) {
    case OUT_XML:
        rc = fmu_write_xml(&FMU_MODEL, fmi, src, f);
        break;
    case OUT_BUILD:
        rc = fmu_write_build_description(&FMU_MODEL, src, f);
        break;
    case OUT_DOC:
        rc = fmu_write_doc(&FMU_MODEL, fmi, eq, conv, platforms, f);
        break;
    case OUT_TERMINALS:
        rc = fmu_write_terminals(&FMU_MODEL, f);
        break;
    case OUT_LS_MANIFEST:
        rc = fmu_write_lsbus_manifest(&FMU_MODEL, f);
        break;
    }
    if (fclose(f) != 0) {
        perror(path);
        rc = 1;
    }
    return rc;
}

int main(int argc, char **argv)
{
    int fmi = 0;
    const char *xml = NULL, *build = NULL, *doc = NULL, *eq_path = NULL, *conv_path = NULL;
    const char *platforms = NULL, *terminals = NULL, *ls_manifest = NULL;
    const char **files = calloc((size_t)argc, sizeof *files);
    size_t n_files = 0;
    if (files == NULL) {
        return 1;
    }
    for (int i = 1; i < argc; ++i) {
        const int has_value = i + 1 < argc;
        if (strcmp(argv[i], "--fmi") == 0 && has_value) {
            fmi = atoi(argv[++i]);
        } else if (strcmp(argv[i], "--xml") == 0 && has_value) {
            xml = argv[++i];
        } else if (strcmp(argv[i], "--build-description") == 0 && has_value) {
            build = argv[++i];
        } else if (strcmp(argv[i], "--doc") == 0 && has_value) {
            doc = argv[++i];
        } else if (strcmp(argv[i], "--equations") == 0 && has_value) {
            eq_path = argv[++i];
        } else if (strcmp(argv[i], "--conventions") == 0 && has_value) {
            conv_path = argv[++i];
        } else if (strcmp(argv[i], "--terminals") == 0 && has_value) {
            terminals = argv[++i];
        } else if (strcmp(argv[i], "--ls-bus-manifest") == 0 && has_value) {
            ls_manifest = argv[++i];
        } else if (strcmp(argv[i], "--platforms") == 0 && has_value) {
            platforms = argv[++i];
        } else if (argv[i][0] == '-') {
            fprintf(stderr, "%s: unknown or incomplete option %s\n", argv[0], argv[i]);
            free(files);
            return 2;
        } else {
            files[n_files++] = argv[i];
        }
    }
    if ((fmi != 2 && fmi != 3) ||
        (doc != NULL && (conv_path == NULL || platforms == NULL || platforms[0] == '\0'))) {
        fprintf(stderr,
                "usage: %s --fmi 2|3 [--xml OUT] [--build-description OUT] [--doc OUT "
                "[--equations FRAGMENT] --conventions FRAGMENT --platforms A,B,...] "
                "[SOURCE...]\n",
                argv[0]);
        free(files);
        return 2;
    }
    const fmu_sources src = {files, n_files};
    int rc = 0;
    if (xml != NULL) {
        rc |= write_one(OUT_XML, xml, fmi, src, NULL, NULL, NULL);
    }
    if (build != NULL) {
        rc |= write_one(OUT_BUILD, build, fmi, src, NULL, NULL, NULL);
    }
    if (terminals != NULL) {
        rc |= write_one(OUT_TERMINALS, terminals, fmi, src, NULL, NULL, NULL);
    }
    if (ls_manifest != NULL) {
        rc |= write_one(OUT_LS_MANIFEST, ls_manifest, fmi, src, NULL, NULL, NULL);
    }
    if (doc != NULL) {
        char *eq = eq_path != NULL ? slurp(eq_path) : NULL;
        char *conv = slurp(conv_path);
        rc |= ((eq_path != NULL && eq == NULL) || conv == NULL)
                  ? 1
                  : write_one(OUT_DOC, doc, fmi, src, eq, conv, platforms);
        free(eq);
        free(conv);
    }
    free(files);
    return rc;
}
