/**
 * @file rrr_fmi_import.h
 * @brief The project's one small importer of its own FMUs (FMI 2.0 and 3.0), shared by the CAN
 *        bench's plant node (c_src/hil/nodes/hil_fmu.c), the portable run tool
 *        (tests/c/fmu_run) and the two FMU test harnesses. Not installed: an internal static
 *        library.
 *
 * What it does:
 * - reads modelDescription.xml whole, with a size limit, refusing empty files and NUL bytes;
 * - scans it with a bounded tag and attribute scanner (every read stays inside the text; a
 *   truncated file, an unterminated tag or attribute value, an oversized value, a missing
 *   CoSimulation element or variable is an error with a message, never a crash);
 * - indexes the variables of <ModelVariables> (name, value reference, type, causality, the
 *   element that carries start/derivative/nominal) for lookups by name and by value reference;
 * - loads the binary (dlopen, or LoadLibraryA on Windows) from binaries/<platform>/ and its
 *   symbols, and builds the resource location.
 *
 * No globals: every call works on the caller's structs. Errors: functions return 0 on success
 * and nonzero on failure, with a message in the caller's buffer (err, errn) where one is taken.
 */
#ifndef RRR_FMI_IMPORT_H
#define RRR_FMI_IMPORT_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/** Largest modelDescription.xml accepted, bytes (ours are about 50 KiB). */
#define RRR_FMI_XML_MAX ((size_t)8 << 20)
/** Most variables indexed. */
#define RRR_FMI_VARS_MAX 4096
/** Longest variable name (with the NUL). */
#define RRR_FMI_NAME_MAX 128

/** Result of the attribute scanner. */
enum {
    RRR_FMI_OK = 0,
    RRR_FMI_ABSENT = 1,    /**< the element has no such attribute */
    RRR_FMI_MALFORMED = 2, /**< the tag is cut off or its attributes are not name="value" */
    RRR_FMI_TOO_LONG = 3   /**< the value does not fit the caller's buffer */
};

/** One tag of the text: [begin, end) runs from '<' to just past '>'. */
typedef struct rrr_fmi_tag {
    const char *begin;
    const char *end;
    const char *name; /**< the element name (not NUL-terminated) */
    size_t name_len;
    int closing;      /**< </name> */
    int empty;        /**< <name .../> */
} rrr_fmi_tag;

/** One variable of <ModelVariables>. Pointers point into rrr_fmi_md.xml. */
typedef struct rrr_fmi_var {
    char name[RRR_FMI_NAME_MAX];
    unsigned long vr;     /**< valueReference */
    char type[24];        /**< FMI 2: the type child (Real, Boolean...); FMI 3: the element name */
    char causality[24];   /**< "" when absent (FMI default: local) */
    rrr_fmi_tag elem;     /**< FMI 2: <ScalarVariable ...>; FMI 3: the variable's element */
    rrr_fmi_tag type_elem; /**< where start, derivative and nominal are: FMI 2 the type child */
} rrr_fmi_var;

/** A parsed modelDescription.xml. */
typedef struct rrr_fmi_md {
    char *xml;          /**< the whole text, NUL-terminated (heap) */
    size_t len;
    int fmi;            /**< 2 or 3 (fmiVersion) */
    char id[64];        /**< <CoSimulation modelIdentifier> */
    char me_id[64];     /**< <ModelExchange modelIdentifier>; "" when there is none */
    char token[128];    /**< FMI 2 guid, FMI 3 instantiationToken */
    rrr_fmi_var *vars;  /**< heap, nvars entries, in document order (FMI 2 index = i + 1) */
    size_t nvars;
} rrr_fmi_md;

/** Reads a whole file (at most max bytes) as a NUL-terminated string into *text (malloc'ed;
 *  *len its length). Refuses a missing, empty or larger file and one holding a NUL byte. */
int rrr_fmi_read_file(const char *path, size_t max, char **text, size_t *len, char *err,
                      size_t errn);

/** The next tag at or after p in [p, end) (comments, <?...?> and <!...> skipped): 0 and *tag;
 *  RRR_FMI_ABSENT at the end of the text; RRR_FMI_MALFORMED for a tag cut off (quoted values
 *  are skipped whole, so '>' inside one does not end the tag). */
int rrr_fmi_next_tag(const char *p, const char *end, rrr_fmi_tag *tag);

/** The next start tag (or empty tag) named name in [p, end), or RRR_FMI_ABSENT /
 *  RRR_FMI_MALFORMED. */
int rrr_fmi_find_tag(const char *p, const char *end, const char *name, rrr_fmi_tag *tag);

/** Value of attribute attr of tag (entities are not decoded; ours have none): see the enum. */
int rrr_fmi_attr(const rrr_fmi_tag *tag, const char *attr, char *out, size_t n);

/** Parses text (taking ownership: freed by rrr_fmi_md_free, also on failure): fmiVersion (2.0
 *  or 3.0), the CoSimulation modelIdentifier, ModelExchange's if any, the guid or
 *  instantiationToken and the variables. */
int rrr_fmi_md_parse(rrr_fmi_md *md, char *text, size_t len, char *err, size_t errn);

/** rrr_fmi_read_file(<dir>/modelDescription.xml) then rrr_fmi_md_parse. */
int rrr_fmi_md_load(rrr_fmi_md *md, const char *dir, char *err, size_t errn);

/** Frees what md holds (idempotent; md zeroed). */
void rrr_fmi_md_free(rrr_fmi_md *md);

/** The variable called name, or NULL. */
const rrr_fmi_var *rrr_fmi_md_var(const rrr_fmi_md *md, const char *name);

/** The variable with value reference vr and a type of the given kind (NULL: any), or NULL. */
const rrr_fmi_var *rrr_fmi_md_var_by_vr(const rrr_fmi_md *md, unsigned long vr,
                                        const char *type);

/** Value reference of variable name; type, when not NULL, must match its type ("Real" matches
 *  FMI 3's "Float64" and the reverse). 0, or nonzero with a message naming the variable. */
int rrr_fmi_md_vr(const rrr_fmi_md *md, const char *name, const char *type, unsigned long *vr,
                  char *err, size_t errn);

/** Attribute attr (start, derivative, nominal...) of variable var's type element: the enum. */
int rrr_fmi_var_attr(const rrr_fmi_var *var, const char *attr, char *out, size_t n);

/** Start value of variable name as text ("" when it has none): 0, or nonzero (no variable). */
int rrr_fmi_md_start(const rrr_fmi_md *md, const char *name, char *out, size_t n);

/** This build's platform folder below binaries/ for FMI version fmi (2 or 3), e.g. linux64. */
const char *rrr_fmi_platform(int fmi);
/** This build's shared-library suffix: ".so", ".dll" or ".dylib". */
const char *rrr_fmi_lib_ext(void);

/** binaries/<platform>/<id><ext> below dir for this build's platform and FMI version. */
int rrr_fmi_binary_path(char *out, size_t n, const char *dir, int fmi, const char *id);

/** file://<absolute dir>/resources (FMI 2's fmuResourceLocation). */
int rrr_fmi_resource_uri(char *out, size_t n, const char *dir);

/** A loaded shared library. */
typedef struct rrr_fmi_lib {
    void *handle;
} rrr_fmi_lib;

/** dlopen / LoadLibraryA. */
int rrr_fmi_lib_open(rrr_fmi_lib *lib, const char *path, char *err, size_t errn);
/** Looks up name and copies the function pointer into *dst (size bytes, sizeof a pointer). */
int rrr_fmi_lib_sym(const rrr_fmi_lib *lib, const char *name, void *dst, size_t size, char *err,
                    size_t errn);
/** dlclose / FreeLibrary (idempotent). */
void rrr_fmi_lib_close(rrr_fmi_lib *lib);

#ifdef __cplusplus
}
#endif

#endif /* RRR_FMI_IMPORT_H */
