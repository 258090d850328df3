/* The project's importer of its own FMUs (see rrr_fmi_import.h). */
#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#else
#define _XOPEN_SOURCE 700 /* realpath */
#endif

#include "rrr_fmi_import.h"

#include <ctype.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#endif

/* ---- platform: binaries/<folder>/<id><ext>, chosen at compile time ---------------------------- */

#if defined(_WIN32)
#define LIB_EXT ".dll"
#if defined(_WIN64) && (defined(__x86_64__) || defined(_M_X64))
#define FMI2_PLATFORM "win64"
#define FMI3_PLATFORM "x86_64-windows"
#elif defined(_WIN64) && (defined(__aarch64__) || defined(_M_ARM64))
#define FMI2_PLATFORM "win64"
#define FMI3_PLATFORM "aarch64-windows"
#else
#define FMI2_PLATFORM "win32"
#define FMI3_PLATFORM "x86-windows"
#endif
#elif defined(__APPLE__)
#define LIB_EXT ".dylib"
#define FMI2_PLATFORM "darwin64"
#if defined(__aarch64__)
#define FMI3_PLATFORM "aarch64-darwin"
#else
#define FMI3_PLATFORM "x86_64-darwin"
#endif
#elif defined(__linux__)
#define LIB_EXT ".so"
#if defined(__x86_64__)
#define FMI2_PLATFORM "linux64"
#define FMI3_PLATFORM "x86_64-linux"
#elif defined(__aarch64__)
#define FMI2_PLATFORM "linux64"
#define FMI3_PLATFORM "aarch64-linux"
#elif defined(__i386__)
#define FMI2_PLATFORM "linux32"
#define FMI3_PLATFORM "x86-linux"
#else
#error "rrr_fmi_import: unknown Linux architecture"
#endif
#else
#error "rrr_fmi_import: unknown platform"
#endif

#define PATH_LEN 4096

#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static int fail(char *err, size_t errn, const char *fmt, ...)
{
    if (err != NULL && errn > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errn, fmt, ap);
        va_end(ap);
    }
    return 1;
}

/* ---- files ------------------------------------------------------------------------------------ */

int rrr_fmi_read_file(const char *path, size_t max, char **text, size_t *len, char *err,
                      size_t errn)
{
    *text = NULL;
    *len = 0;
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) {
        return fail(err, errn, "cannot open %.300s", path);
    }
    long n = -1;
    if (fseek(fp, 0, SEEK_END) == 0) {
        n = ftell(fp);
    }
    if (n < 0 || fseek(fp, 0, SEEK_SET) != 0) {
        fclose(fp);
        return fail(err, errn, "cannot read %.300s (not a regular file?)", path);
    }
    if (n == 0 || (unsigned long)n > max) {
        fclose(fp);
        return fail(err, errn, "%.300s is %s (%ld bytes; at most %lu)", path,
                    n == 0 ? "empty" : "too large", n, (unsigned long)max);
    }
    char *buf = malloc((size_t)n + 1u);
    if (buf == NULL) {
        fclose(fp);
        return fail(err, errn, "out of memory reading %.300s", path);
    }
    const size_t got = fread(buf, 1, (size_t)n, fp);
    fclose(fp);
    if (got != (size_t)n) {
        free(buf);
        return fail(err, errn, "short read of %.300s", path);
    }
    buf[got] = '\0';
    if (memchr(buf, '\0', got) != NULL) {
        free(buf);
        return fail(err, errn, "%.300s holds a NUL byte: not an XML text", path);
    }
    *text = buf;
    *len = got;
    return 0;
}

/* ---- the scanner ------------------------------------------------------------------------------ */

static const char *find_bytes(const char *p, const char *end, const char *s)
{
    const size_t n = strlen(s);
    for (; p != NULL && (size_t)(end - p) >= n; ++p) {
        p = memchr(p, s[0], (size_t)(end - p));
        if (p == NULL || (size_t)(end - p) < n) {
            return NULL;
        }
        if (memcmp(p, s, n) == 0) {
            return p;
        }
    }
    return NULL;
}

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

int rrr_fmi_next_tag(const char *p, const char *end, rrr_fmi_tag *tag)
{
    for (;;) {
        p = p < end ? memchr(p, '<', (size_t)(end - p)) : NULL;
        if (p == NULL) {
            return RRR_FMI_ABSENT;
        }
        if (end - p >= 4 && memcmp(p, "<!--", 4) == 0) {
            const char *q = find_bytes(p + 4, end, "-->");
            if (q == NULL) {
                return RRR_FMI_MALFORMED;
            }
            p = q + 3;
            continue;
        }
        if (end - p >= 2 && (p[1] == '?' || p[1] == '!')) {
            const char *q = memchr(p, '>', (size_t)(end - p));
            if (q == NULL) {
                return RRR_FMI_MALFORMED;
            }
            p = q + 1;
            continue;
        }
        const char *q = p + 1;
        tag->closing = q < end && *q == '/';
        q += tag->closing;
        const char *name = q;
        while (q < end && !is_space(*q) && *q != '>' && *q != '/' && *q != '<') {
            ++q;
        }
        if (q == name) {
            return RRR_FMI_MALFORMED;
        }
        tag->begin = p;
        tag->name = name;
        tag->name_len = (size_t)(q - name);
        while (q < end && *q != '>') {
            if (*q == '"' || *q == '\'') {
                const char *r = memchr(q + 1, *q, (size_t)(end - q - 1));
                if (r == NULL) {
                    return RRR_FMI_MALFORMED; /* an unterminated attribute value */
                }
                q = r + 1;
            } else if (*q == '<') {
                return RRR_FMI_MALFORMED; /* a tag inside a tag: the first one is cut off */
            } else {
                ++q;
            }
        }
        if (q >= end) {
            return RRR_FMI_MALFORMED;
        }
        tag->empty = !tag->closing && q[-1] == '/';
        tag->end = q + 1;
        return RRR_FMI_OK;
    }
}

static int tag_is(const rrr_fmi_tag *tag, const char *name)
{
    const size_t n = strlen(name);
    return tag->name_len == n && memcmp(tag->name, name, n) == 0;
}

int rrr_fmi_find_tag(const char *p, const char *end, const char *name, rrr_fmi_tag *tag)
{
    for (;;) {
        const int rc = rrr_fmi_next_tag(p, end, tag);
        if (rc != RRR_FMI_OK) {
            return rc;
        }
        if (!tag->closing && tag_is(tag, name)) {
            return RRR_FMI_OK;
        }
        p = tag->end;
    }
}

int rrr_fmi_attr(const rrr_fmi_tag *tag, const char *attr, char *out, size_t n)
{
    const char *p = tag->name + tag->name_len;
    const char *stop = tag->end - 1; /* the '>' */
    const size_t attr_len = strlen(attr);
    for (;;) {
        while (p < stop && is_space(*p)) {
            ++p;
        }
        if (p >= stop) {
            return RRR_FMI_ABSENT;
        }
        if (*p == '/') {
            return p + 1 == stop ? RRR_FMI_ABSENT : RRR_FMI_MALFORMED;
        }
        const char *an = p;
        while (p < stop && *p != '=' && !is_space(*p)) {
            ++p;
        }
        const size_t alen = (size_t)(p - an);
        while (p < stop && is_space(*p)) {
            ++p;
        }
        if (p >= stop || *p != '=') {
            return RRR_FMI_MALFORMED;
        }
        ++p;
        while (p < stop && is_space(*p)) {
            ++p;
        }
        if (p >= stop || (*p != '"' && *p != '\'')) {
            return RRR_FMI_MALFORMED;
        }
        const char *v = p + 1;
        const char *e = memchr(v, *p, (size_t)(stop - v));
        if (e == NULL) {
            return RRR_FMI_MALFORMED;
        }
        if (alen == attr_len && memcmp(an, attr, alen) == 0) {
            if (n == 0 || (size_t)(e - v) >= n) {
                return RRR_FMI_TOO_LONG;
            }
            memcpy(out, v, (size_t)(e - v));
            out[e - v] = '\0';
            return RRR_FMI_OK;
        }
        p = e + 1;
    }
}

/* An attribute that must be there: 0, or a message naming element and attribute. */
static int need_attr(const rrr_fmi_tag *tag, const char *attr, char *out, size_t n, char *err,
                     size_t errn)
{
    static const char *const why[] = {"", "has no", "is malformed before", "has too long a"};
    const int rc = rrr_fmi_attr(tag, attr, out, n);
    if (rc != RRR_FMI_OK) {
        return fail(err, errn, "modelDescription.xml: <%.*s> %s %s attribute",
                    (int)(tag->name_len < 40 ? tag->name_len : 40), tag->name, why[rc], attr);
    }
    return 0;
}

static int parse_ulong(const char *s, unsigned long *v)
{
    if (*s < '0' || *s > '9' || strlen(s) > 10) {
        return 1;
    }
    char *tail = NULL;
    const unsigned long x = strtoul(s, &tail, 10);
    if (*tail != '\0' || x > 0xFFFFFFFFul) {
        return 1;
    }
    *v = x;
    return 0;
}

/* ---- the model description -------------------------------------------------------------------- */

static int add_var(rrr_fmi_md *md, size_t *cap, const rrr_fmi_tag *elem, char *err, size_t errn)
{
    if (md->nvars == RRR_FMI_VARS_MAX) {
        return fail(err, errn, "modelDescription.xml: more than %d variables",
                    RRR_FMI_VARS_MAX);
    }
    if (md->nvars == *cap) {
        const size_t ncap = *cap == 0 ? 64 : 2 * *cap;
        rrr_fmi_var *v = realloc(md->vars, ncap * sizeof *v);
        if (v == NULL) {
            return fail(err, errn, "out of memory indexing the variables");
        }
        md->vars = v;
        *cap = ncap;
    }
    rrr_fmi_var *v = &md->vars[md->nvars];
    memset(v, 0, sizeof *v);
    v->elem = *elem;
    v->type_elem = *elem;
    char vr[16];
    if (need_attr(elem, "name", v->name, sizeof v->name, err, errn) != 0 ||
        need_attr(elem, "valueReference", vr, sizeof vr, err, errn) != 0) {
        return 1;
    }
    if (parse_ulong(vr, &v->vr) != 0) {
        return fail(err, errn, "modelDescription.xml: variable %s: valueReference \"%s\" is not "
                    "a 32-bit unsigned integer", v->name, vr);
    }
    const int rc = rrr_fmi_attr(elem, "causality", v->causality, sizeof v->causality);
    if (rc != RRR_FMI_OK && rc != RRR_FMI_ABSENT) {
        return fail(err, errn, "modelDescription.xml: variable %s: bad causality", v->name);
    }
    if (md->fmi == 3) {
        snprintf(v->type, sizeof v->type, "%.*s", (int)(elem->name_len < 23 ? elem->name_len : 23),
                 elem->name);
    }
    md->nvars++;
    return 0;
}

static int parse_vars(rrr_fmi_md *md, const char *end, char *err, size_t errn)
{
    rrr_fmi_tag t;
    int rc = rrr_fmi_find_tag(md->xml, end, "ModelVariables", &t);
    if (rc != RRR_FMI_OK) {
        return fail(err, errn, "modelDescription.xml: %s", rc == RRR_FMI_ABSENT
                    ? "no <ModelVariables>" : "a tag is cut off before <ModelVariables>");
    }
    if (t.empty) {
        return 0;
    }
    size_t cap = 0;
    int depth = 0;       /* 0: directly inside <ModelVariables> */
    int want_type = 0;   /* FMI 2: the next child of the current ScalarVariable is its type */
    for (const char *p = t.end;; p = t.end) {
        rc = rrr_fmi_next_tag(p, end, &t);
        if (rc != RRR_FMI_OK) {
            return fail(err, errn, "modelDescription.xml: %s inside <ModelVariables> (after %lu "
                        "variables)", rc == RRR_FMI_ABSENT ? "the text ends" : "a tag is cut off",
                        (unsigned long)md->nvars);
        }
        if (t.closing) {
            if (depth == 0) {
                if (!tag_is(&t, "ModelVariables")) {
                    return fail(err, errn, "modelDescription.xml: </%.*s> closes <ModelVariables>",
                                (int)(t.name_len < 40 ? t.name_len : 40), t.name);
                }
                return 0;
            }
            --depth;
            want_type = 0;
            continue;
        }
        if (depth == 0) {
            if (md->fmi == 2 && !tag_is(&t, "ScalarVariable")) {
                return fail(err, errn, "modelDescription.xml: <%.*s> in <ModelVariables>",
                            (int)(t.name_len < 40 ? t.name_len : 40), t.name);
            }
            if (add_var(md, &cap, &t, err, errn) != 0) {
                return 1;
            }
            want_type = md->fmi == 2 && !t.empty;
        } else if (want_type) {
            rrr_fmi_var *v = &md->vars[md->nvars - 1];
            v->type_elem = t;
            snprintf(v->type, sizeof v->type, "%.*s", (int)(t.name_len < 23 ? t.name_len : 23),
                     t.name);
            want_type = 0;
        }
        if (!t.empty) {
            ++depth;
        }
    }
}

int rrr_fmi_md_parse(rrr_fmi_md *md, char *text, size_t len, char *err, size_t errn)
{
    memset(md, 0, sizeof *md);
    md->xml = text;
    md->len = len;
    if (text == NULL || len == 0 || text[len] != '\0' || memchr(text, '\0', len) != NULL) {
        rrr_fmi_md_free(md);
        return fail(err, errn, "modelDescription.xml: empty, or not a NUL-free text");
    }
    const char *end = text + len;
    rrr_fmi_tag root, cs, me;
    char version[16];
    int rc = rrr_fmi_find_tag(text, end, "fmiModelDescription", &root);
    if (rc != RRR_FMI_OK) {
        rrr_fmi_md_free(md);
        return fail(err, errn, "modelDescription.xml: %s", rc == RRR_FMI_ABSENT
                    ? "no <fmiModelDescription> element" : "a tag is cut off");
    }
    if (need_attr(&root, "fmiVersion", version, sizeof version, err, errn) != 0) {
        rrr_fmi_md_free(md);
        return 1;
    }
    md->fmi = strcmp(version, "2.0") == 0 ? 2 : strncmp(version, "3.", 2) == 0 ? 3 : 0;
    if (md->fmi == 0) {
        rrr_fmi_md_free(md);
        return fail(err, errn, "modelDescription.xml: fmiVersion \"%s\" is neither 2.0 nor 3.x",
                    version);
    }
    if (need_attr(&root, md->fmi == 2 ? "guid" : "instantiationToken", md->token,
                  sizeof md->token, err, errn) != 0) {
        rrr_fmi_md_free(md);
        return 1;
    }
    rc = rrr_fmi_find_tag(root.end, end, "CoSimulation", &cs);
    if (rc != RRR_FMI_OK) {
        rrr_fmi_md_free(md);
        return fail(err, errn, "modelDescription.xml: %s", rc == RRR_FMI_ABSENT
                    ? "no <CoSimulation> element" : "a tag is cut off before <CoSimulation>");
    }
    if (need_attr(&cs, "modelIdentifier", md->id, sizeof md->id, err, errn) != 0) {
        rrr_fmi_md_free(md);
        return 1;
    }
    if (rrr_fmi_find_tag(root.end, end, "ModelExchange", &me) == RRR_FMI_OK &&
        need_attr(&me, "modelIdentifier", md->me_id, sizeof md->me_id, err, errn) != 0) {
        rrr_fmi_md_free(md);
        return 1;
    }
    if (parse_vars(md, end, err, errn) != 0) {
        rrr_fmi_md_free(md);
        return 1;
    }
    return 0;
}

int rrr_fmi_md_load(rrr_fmi_md *md, const char *dir, char *err, size_t errn)
{
    char path[PATH_LEN];
    char *text = NULL;
    size_t len = 0;
    memset(md, 0, sizeof *md);
    if (snprintf(path, sizeof path, "%s/modelDescription.xml", dir) >= (int)sizeof path) {
        return fail(err, errn, "path too long: %.300s", dir);
    }
    if (rrr_fmi_read_file(path, RRR_FMI_XML_MAX, &text, &len, err, errn) != 0) {
        return 1;
    }
    return rrr_fmi_md_parse(md, text, len, err, errn);
}

void rrr_fmi_md_free(rrr_fmi_md *md)
{
    free(md->xml);
    free(md->vars);
    memset(md, 0, sizeof *md);
}

const rrr_fmi_var *rrr_fmi_md_var(const rrr_fmi_md *md, const char *name)
{
    for (size_t i = 0; i < md->nvars; ++i) {
        if (strcmp(md->vars[i].name, name) == 0) {
            return &md->vars[i];
        }
    }
    return NULL;
}

/* "Real" (FMI 2) and "Float64" (FMI 3) name one kind. */
static int type_matches(const char *have, const char *want)
{
    if (want == NULL || strcmp(have, want) == 0) {
        return 1;
    }
    const int have_real = strcmp(have, "Real") == 0 || strcmp(have, "Float64") == 0;
    const int want_real = strcmp(want, "Real") == 0 || strcmp(want, "Float64") == 0;
    return have_real && want_real;
}

const rrr_fmi_var *rrr_fmi_md_var_by_vr(const rrr_fmi_md *md, unsigned long vr, const char *type)
{
    for (size_t i = 0; i < md->nvars; ++i) {
        if (md->vars[i].vr == vr && type_matches(md->vars[i].type, type)) {
            return &md->vars[i];
        }
    }
    return NULL;
}

int rrr_fmi_md_vr(const rrr_fmi_md *md, const char *name, const char *type, unsigned long *vr,
                  char *err, size_t errn)
{
    const rrr_fmi_var *v = rrr_fmi_md_var(md, name);
    if (v == NULL) {
        return fail(err, errn, "FMU %s has no variable \"%.200s\"", md->id, name);
    }
    if (!type_matches(v->type, type)) {
        return fail(err, errn, "FMU %s: variable \"%.200s\" is of type %s, not %s", md->id, name,
                    v->type, type);
    }
    *vr = v->vr;
    return 0;
}

int rrr_fmi_var_attr(const rrr_fmi_var *var, const char *attr, char *out, size_t n)
{
    return rrr_fmi_attr(&var->type_elem, attr, out, n);
}

int rrr_fmi_md_start(const rrr_fmi_md *md, const char *name, char *out, size_t n)
{
    const rrr_fmi_var *v = rrr_fmi_md_var(md, name);
    if (n > 0) {
        out[0] = '\0';
    }
    if (v == NULL) {
        return 1;
    }
    const int rc = rrr_fmi_var_attr(v, "start", out, n);
    return rc == RRR_FMI_OK || rc == RRR_FMI_ABSENT ? 0 : 1;
}

/* ---- the binary ------------------------------------------------------------------------------- */

int rrr_fmi_binary_path(char *out, size_t n, const char *dir, int fmi, const char *id)
{
    const int len = snprintf(out, n, "%s/binaries/%s/%s%s", dir,
                             fmi == 2 ? FMI2_PLATFORM : FMI3_PLATFORM, id, LIB_EXT);
    return len < 0 || (size_t)len >= n;
}

int rrr_fmi_resource_uri(char *out, size_t n, const char *dir)
{
    char abs[PATH_LEN];
#ifdef _WIN32
    if (_fullpath(abs, dir, sizeof abs) == NULL) {
        snprintf(abs, sizeof abs, "%s", dir);
    }
    for (char *p = abs; *p != '\0'; ++p) {
        if (*p == '\\') {
            *p = '/';
        }
    }
#else
    char real[PATH_MAX];
    snprintf(abs, sizeof abs, "%s", realpath(dir, real) != NULL ? real : dir);
#endif
    const int len = snprintf(out, n, "file://%s%s/resources", abs[0] == '/' ? "" : "/", abs);
    return len < 0 || (size_t)len >= n;
}

int rrr_fmi_lib_open(rrr_fmi_lib *lib, const char *path, char *err, size_t errn)
{
#ifdef _WIN32
    /* LoadLibrary wants backslashes; "/tmp/x" becomes "\tmp\x" on the current drive (under wine
     * Z:, the Unix root, when started from a Unix directory) */
    char win[PATH_LEN];
    snprintf(win, sizeof win, "%s", path);
    for (char *p = win; *p != '\0'; ++p) {
        if (*p == '/') {
            *p = '\\';
        }
    }
    HMODULE h = LoadLibraryA(win);
    lib->handle = (void *)h;
    if (h == NULL) {
        return fail(err, errn, "LoadLibraryA(%.300s) failed, error %lu", win,
                    (unsigned long)GetLastError());
    }
#else
    lib->handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (lib->handle == NULL) {
        const char *why = dlerror();
        return fail(err, errn, "dlopen %.300s: %.300s", path, why != NULL ? why : "?");
    }
#endif
    return 0;
}

int rrr_fmi_lib_sym(const rrr_fmi_lib *lib, const char *name, void *dst, size_t size, char *err,
                    size_t errn)
{
#ifdef _WIN32
    FARPROC p = GetProcAddress((HMODULE)lib->handle, name);
#else
    void *p = lib->handle != NULL ? dlsym(lib->handle, name) : NULL;
#endif
    if (p == NULL || size != sizeof p) {
        return fail(err, errn, "the FMU binary does not export %s", name);
    }
    /* copied bytewise: no cast between object and function pointers (dlsym) or between function
     * pointer types (GetProcAddress) */
    memcpy(dst, &p, sizeof p);
    return 0;
}

void rrr_fmi_lib_close(rrr_fmi_lib *lib)
{
    if (lib->handle != NULL) {
#ifdef _WIN32
        FreeLibrary((HMODULE)lib->handle);
#else
        dlclose(lib->handle);
#endif
        lib->handle = NULL;
    }
}
