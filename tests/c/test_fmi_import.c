/*
 * The FMU importer (c_src/fmi_import) on our FMUs and on hostile model descriptions: the FMI 2 and
 * FMI 3 plant's XML give the same names, value references and token; every prefix of a real
 * modelDescription.xml (copied into a buffer of exactly that size, so ASan sees any read past
 * it) parses or is refused with a message; crafted files (unterminated attribute, oversized,
 * empty, NUL byte, missing CoSimulation, missing or malformed variables, bad fmiVersion, too long
 * values) are refused with a message that says what is wrong; the binary loads and a missing
 * symbol is named. Run under ASan and UBSan.
 *
 * Usage: test_fmi_import <FMI 2 plant unzip dir> <FMI 3 plant unzip dir> <scratch dir>
 */
#define _POSIX_C_SOURCE 200809L

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rrr_fmi_import.h"
#include "rrr_test.h"

int rrr_fuzz_fmi_import_one(const uint8_t *data, size_t size);

/* Parses a copy of text; expects failure with a message containing needle (NULL: success). */
static void expect_parse(const char *what, const char *text, const char *needle)
{
    const size_t n = strlen(text);
    char *copy = malloc(n + 1);
    CHECK(copy != NULL);
    if (copy == NULL) {
        return;
    }
    memcpy(copy, text, n + 1);
    rrr_fmi_md md;
    char err[256] = "";
    const int rc = rrr_fmi_md_parse(&md, copy, n, err, sizeof err);
    if (needle == NULL) {
        if (rc != 0) {
            fprintf(stderr, "%s: refused: %s\n", what, err);
        }
        CHECK(rc == 0);
        rrr_fmi_md_free(&md);
    } else if (rc == 0 || strstr(err, needle) == NULL) {
        fprintf(stderr, "%s: rc %d, message \"%s\", expected one with \"%s\"\n", what, rc, err,
                needle);
        rrr_test_failures++;
    }
    CHECK(md.xml == NULL || needle == NULL);
}

#define HEAD2 "<?xml version=\"1.0\"?>\n<fmiModelDescription fmiVersion=\"2.0\" guid=\"{g}\">\n"
#define CS "<CoSimulation modelIdentifier=\"m\"/>\n"
#define VAR2(N, VR) "<ScalarVariable name=\"" N "\" valueReference=\"" VR "\"><Real start=\"1\"/>" \
                    "</ScalarVariable>\n"

static void test_crafted(void)
{
    expect_parse("minimal FMI 2", HEAD2 CS "<ModelVariables>" VAR2("x", "3")
                 "</ModelVariables></fmiModelDescription>", NULL);
    expect_parse("'>' in a value, single quotes, comments",
                 HEAD2 "<!-- <CoSimulation modelIdentifier=\"no\"/> -->\n"
                 "<CoSimulation modelIdentifier='m' description=\"a > b\"/>\n<ModelVariables>"
                 "<!-- <ScalarVariable> -->" VAR2("x", "3") "</ModelVariables>", NULL);
    expect_parse("empty", "", "empty");
    expect_parse("no root", "<a/>", "no <fmiModelDescription>");
    expect_parse("bad version", "<fmiModelDescription fmiVersion=\"1.0\" guid=\"g\">",
                 "fmiVersion \"1.0\"");
    expect_parse("no guid", "<fmiModelDescription fmiVersion=\"2.0\">", "no guid");
    expect_parse("FMI 3 without token", "<fmiModelDescription fmiVersion=\"3.0\" guid=\"g\">",
                 "no instantiationToken");
    expect_parse("unterminated attribute", "<fmiModelDescription fmiVersion=\"2.0 guid=\"g\">"
                 CS, "a tag is cut off");
    expect_parse("unterminated last attribute", HEAD2 "<CoSimulation modelIdentifier=\"m/>",
                 "cut off");
    expect_parse("no CoSimulation", HEAD2 "<ModelExchange modelIdentifier=\"m\"/>",
                 "no <CoSimulation>");
    expect_parse("too long modelIdentifier", HEAD2 "<CoSimulation modelIdentifier=\""
                 "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"
                 "\"/>", "too long a modelIdentifier");
    expect_parse("attribute without a value", HEAD2 "<CoSimulation modelIdentifier/>",
                 "malformed before modelIdentifier");
    expect_parse("no ModelVariables", HEAD2 CS "</fmiModelDescription>", "no <ModelVariables>");
    expect_parse("truncated ModelVariables", HEAD2 CS "<ModelVariables>" VAR2("x", "3"),
                 "the text ends inside <ModelVariables> (after 1 variables)");
    expect_parse("variable without a name", HEAD2 CS "<ModelVariables><ScalarVariable "
                 "valueReference=\"1\"/></ModelVariables>", "<ScalarVariable> has no name");
    expect_parse("variable without a value reference", HEAD2 CS "<ModelVariables>"
                 "<ScalarVariable name=\"x\"/></ModelVariables>", "no valueReference");
    expect_parse("value reference not a number", HEAD2 CS "<ModelVariables>" VAR2("x", "-1")
                 "</ModelVariables>", "valueReference \"-1\"");
    expect_parse("value reference too large", HEAD2 CS "<ModelVariables>" VAR2("x", "4294967296")
                 "</ModelVariables>", "not a 32-bit");
    expect_parse("a foreign element in FMI 2 variables", HEAD2 CS "<ModelVariables><Float64 "
                 "name=\"x\" valueReference=\"1\"/></ModelVariables>", "<Float64> in");
    expect_parse("wrong closing tag", HEAD2 CS "<ModelVariables></ModelStructure>",
                 "</ModelStructure> closes");
    expect_parse("unterminated comment", HEAD2 CS "<!-- <ModelVariables>",
                 "a tag is cut off before <ModelVariables>");

    /* lookups on a small FMI 3 description */
    static const char fmi3[] =
        "<fmiModelDescription fmiVersion=\"3.0\" instantiationToken=\"{t}\">"
        "<ModelExchange modelIdentifier=\"m\"/><CoSimulation modelIdentifier=\"m\"/>"
        "<ModelVariables><Float64 name=\"time\" valueReference=\"0\" causality=\"independent\"/>"
        "<Float64 name=\"x\" valueReference=\"1\" start=\"0.5\" nominal=\"2\"><Dimension "
        "start=\"9\"/></Float64><Boolean name=\"b\" valueReference=\"1\" start=\"true\"/>"
        "</ModelVariables></fmiModelDescription>";
    char *copy = malloc(sizeof fmi3);
    CHECK(copy != NULL);
    if (copy == NULL) {
        return;
    }
    memcpy(copy, fmi3, sizeof fmi3);
    rrr_fmi_md md;
    char err[256] = "";
    CHECK(rrr_fmi_md_parse(&md, copy, sizeof fmi3 - 1, err, sizeof err) == 0);
    CHECK(md.fmi == 3 && md.nvars == 3 && strcmp(md.token, "{t}") == 0);
    CHECK(strcmp(md.id, "m") == 0 && strcmp(md.me_id, "m") == 0);
    unsigned long vr = 99;
    CHECK(rrr_fmi_md_vr(&md, "x", "Real", &vr, err, sizeof err) == 0 && vr == 1);
    CHECK(rrr_fmi_md_vr(&md, "b", "Float64", &vr, err, sizeof err) != 0);
    CHECK(strstr(err, "variable \"b\" is of type Boolean, not Float64") != NULL);
    CHECK(rrr_fmi_md_vr(&md, "y", NULL, &vr, err, sizeof err) != 0);
    CHECK(strstr(err, "FMU m has no variable \"y\"") != NULL);
    char buf[8];
    CHECK(rrr_fmi_md_start(&md, "x", buf, sizeof buf) == 0 && strcmp(buf, "0.5") == 0);
    CHECK(rrr_fmi_md_start(&md, "time", buf, sizeof buf) == 0 && buf[0] == '\0');
    CHECK(rrr_fmi_md_start(&md, "y", buf, sizeof buf) != 0);
    CHECK(rrr_fmi_var_attr(rrr_fmi_md_var(&md, "x"), "nominal", buf, 1) == RRR_FMI_TOO_LONG);
    CHECK(strcmp(rrr_fmi_md_var_by_vr(&md, 1, "Boolean")->name, "b") == 0);
    CHECK(strcmp(rrr_fmi_md_var_by_vr(&md, 1, "Real")->name, "x") == 0);
    CHECK(strcmp(rrr_fmi_md_var(&md, "time")->causality, "independent") == 0);
    rrr_fmi_md_free(&md);
    rrr_fmi_md_free(&md); /* idempotent */
}

static void write_file(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f != NULL) {
        CHECK(fwrite(data, 1, n, f) == n);
        CHECK(fclose(f) == 0);
    }
}

static void expect_load(const char *dir, const char *needle)
{
    rrr_fmi_md md;
    char err[512] = "";
    if (rrr_fmi_md_load(&md, dir, err, sizeof err) == 0 || strstr(err, needle) == NULL) {
        fprintf(stderr, "load %s: message \"%s\", expected one with \"%s\"\n", dir, err, needle);
        rrr_test_failures++;
    }
}

static void test_files(const char *scratch)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/modelDescription.xml", scratch);
    remove(path);
    expect_load(scratch, "cannot open");
    write_file(path, "", 0);
    expect_load(scratch, "is empty");
    write_file(path, "<a>\0</a>", 8);
    expect_load(scratch, "NUL byte");
    /* oversized: one byte over the limit (a sparse file) */
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f != NULL) {
        CHECK(fseek(f, (long)RRR_FMI_XML_MAX, SEEK_SET) == 0);
        CHECK(fputc('x', f) == 'x');
        CHECK(fclose(f) == 0);
    }
    expect_load(scratch, "too large");
    remove(path);
    char *text = NULL;
    size_t len = 0;
    char err[256];
    write_file(path, "abcdef", 6);
    CHECK(rrr_fmi_read_file(path, 5, &text, &len, err, sizeof err) != 0 && text == NULL);
    CHECK(rrr_fmi_read_file(path, 6, &text, &len, err, sizeof err) == 0 && len == 6);
    CHECK(text != NULL && strcmp(text, "abcdef") == 0);
    free(text);
    remove(path);
}

/* Every prefix of the real file (the first 4 KiB byte by byte, then every 61st) parses or is
 * refused with a message; a prefix parses only when it holds all of <ModelVariables>. */
static void test_prefixes(const char *xml, size_t len)
{
    size_t n_ok = 0, n_refused = 0;
    for (size_t k = 0; k < len; k += k < 4096 ? 1 : 61) {
        const int rc = rrr_fuzz_fmi_import_one((const uint8_t *)xml, k);
        CHECK(rc == 0 || rc == 1);
        if (rc == 0) {
            ++n_ok;
            char *cut = malloc(k + 1);
            if (cut != NULL) {
                memcpy(cut, xml, k);
                cut[k] = '\0';
                CHECK(strstr(cut, "</ModelVariables>") != NULL);
                free(cut);
            }
        } else {
            ++n_refused;
        }
    }
    CHECK(rrr_fuzz_fmi_import_one((const uint8_t *)xml, len) == 0);
    CHECK(n_refused > 4096);
    printf("prefixes: %lu parsed, %lu refused with a message\n", (unsigned long)n_ok,
           (unsigned long)n_refused);
}

static void test_fmus(const char *dir2, const char *dir3)
{
    rrr_fmi_md a, b;
    char err[512] = "";
    CHECK(rrr_fmi_md_load(&a, dir2, err, sizeof err) == 0);
    CHECK(rrr_fmi_md_load(&b, dir3, err, sizeof err) == 0);
    if (a.xml == NULL || b.xml == NULL) {
        fprintf(stderr, "%s\n", err);
        rrr_fmi_md_free(&a);
        rrr_fmi_md_free(&b);
        return;
    }
    CHECK(a.fmi == 2 && b.fmi == 3);
    CHECK(strcmp(a.id, "rrr_plant") == 0 && strcmp(b.id, a.id) == 0 && strcmp(a.me_id, a.id) == 0);
    CHECK(strcmp(a.token, b.token) == 0);
    /* every FMI 2 Real has the same value reference, type and start in FMI 3 */
    size_t n_real = 0;
    for (size_t i = 0; i < a.nvars; ++i) {
        const rrr_fmi_var *v = &a.vars[i];
        if (strcmp(v->type, "Real") != 0) {
            continue;
        }
        ++n_real;
        unsigned long vr = 0;
        CHECK(rrr_fmi_md_vr(&b, v->name, "Float64", &vr, err, sizeof err) == 0 && vr == v->vr);
        char s2[64], s3[64];
        CHECK(rrr_fmi_md_start(&a, v->name, s2, sizeof s2) == 0);
        CHECK(rrr_fmi_md_start(&b, v->name, s3, sizeof s3) == 0);
        if (strcmp(s2, s3) != 0) {
            fprintf(stderr, "%s: start %s (FMI 2) vs %s (FMI 3)\n", v->name, s2, s3);
            rrr_test_failures++;
        }
    }
    CHECK(n_real > 20);
    test_prefixes(a.xml, a.len);
    test_prefixes(b.xml, b.len);

    /* the binary: loaded, a symbol found, a missing one named */
    char path[4096];
    CHECK(rrr_fmi_binary_path(path, sizeof path, dir2, 2, a.id) == 0);
    CHECK(rrr_fmi_binary_path(path, 8, dir2, 2, a.id) != 0);
    CHECK(rrr_fmi_binary_path(path, sizeof path, dir2, 2, a.id) == 0);
    rrr_fmi_lib lib = {NULL};
    CHECK(rrr_fmi_lib_open(&lib, path, err, sizeof err) == 0);
    void (*fn)(void) = NULL;
    CHECK(rrr_fmi_lib_sym(&lib, "fmi2Instantiate", &fn, sizeof fn, err, sizeof err) == 0);
    CHECK(fn != NULL);
    CHECK(rrr_fmi_lib_sym(&lib, "fmi2NoSuchCall", &fn, sizeof fn, err, sizeof err) != 0);
    CHECK(strstr(err, "does not export fmi2NoSuchCall") != NULL);
    rrr_fmi_lib_close(&lib);
    rrr_fmi_lib_close(&lib);
    CHECK(rrr_fmi_lib_open(&lib, "/nonexistent/x.so", err, sizeof err) != 0);
    CHECK(strstr(err, "/nonexistent/x.so") != NULL);
    CHECK(rrr_fmi_resource_uri(path, sizeof path, dir2) == 0);
    CHECK(strncmp(path, "file:///", 8) == 0 && strstr(path, "/resources") != NULL);
    rrr_fmi_md_free(&a);
    rrr_fmi_md_free(&b);
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: test_fmi_import <FMI 2 plant dir> <FMI 3 plant dir> <scratch>\n");
        return 2;
    }
    test_crafted();
    test_files(argv[3]);
    test_fmus(argv[1], argv[2]);
    if (rrr_test_failures != 0) {
        fprintf(stderr, "%d check(s) failed\n", rrr_test_failures);
        return 1;
    }
    printf("test_fmi_import: all checks passed\n");
    return 0;
}
