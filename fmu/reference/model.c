/*
 * The reference FMU: its variable table, the reader of resources/reference.csv and the
 * interpolation between the samples. No model here: the table holds the joint reference and
 * the tip reference as the table writer computed them (rrr ssp: the writing task's closed-form
 * IK and path), so this FMU needs no robot parameters.
 *
 * The table (UTF-8 or ASCII text, one sample per line, at most REF_MAX_ROWS samples):
 *
 *   t,q_ref[1],q_ref[2],q_ref[3],qd_ref[1],...,qdd_ref[3],x_ref.x,...,xd_ref.x,...,xdd_ref.z
 *   0,0.1,...
 *
 * the header exactly as in `columns` below, then REF_COLUMNS finite decimal numbers per line
 * separated by commas (the C locale's notation whatever the importer's locale), times strictly
 * increasing, at least two samples; a line may end in CR LF. Anything else is refused with
 * fmi2Error / fmi3Error and a message naming the line and the column.
 *
 * Interpolation: on [t_k, t_k+1] each coordinate is the quintic polynomial that matches the
 * position, velocity and acceleration of both samples (Hermite). qd_ref and qdd_ref are its
 * exact first and second derivatives, so the three outputs are consistent at every time, the
 * interpolant is C2 across samples, and at a sample time the outputs are the sample bit for
 * bit. Outside [t_0, t_N] the end sample's position is held at rest (velocity and acceleration
 * 0).
 */
#include "config.h"
#include "rrr/rrr.h" /* RRR_SAMPLE_TIME_DEFAULT */

#include <ctype.h>
#include <errno.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define T reference_data

static const char *const columns[REF_COLUMNS] = {
    "t",         "q_ref[1]",  "q_ref[2]",  "q_ref[3]",  "qd_ref[1]", "qd_ref[2]", "qd_ref[3]",
    "qdd_ref[1]", "qdd_ref[2]", "qdd_ref[3]", "x_ref.x", "x_ref.y",  "x_ref.z",  "xd_ref.x",
    "xd_ref.y",  "xd_ref.z",  "xdd_ref.x", "xdd_ref.y", "xdd_ref.z"};

#define OUTPUT(VR, NAME, DESC, UNIT, MEMBER)                                                   \
    FMU_ROW(VR, FMU_REAL, FMU_OUTPUT, FMU_CONTINUOUS, NAME, DESC, UNIT, T, MEMBER)
#define JOINT_OUTPUTS(VR, N, WHAT, UNIT, M)                                                    \
    OUTPUT((VR) + 0, N "[1]", WHAT " of joint 1 at t + lookahead", UNIT, M[0]),                \
    OUTPUT((VR) + 1, N "[2]", WHAT " of joint 2 at t + lookahead", UNIT, M[1]),                \
    OUTPUT((VR) + 2, N "[3]", WHAT " of joint 3 at t + lookahead", UNIT, M[2])

static const fmu_variable reference_vars[] = {
    JOINT_OUTPUTS(vr_q_ref, "q_ref", "reference position", "rad", q_ref),
    JOINT_OUTPUTS(vr_qd_ref, "qd_ref", "reference velocity (the derivative of q_ref)", "rad/s",
                  qd_ref),
    JOINT_OUTPUTS(vr_qdd_ref, "qdd_ref", "reference acceleration (the derivative of qd_ref)",
                  "rad/s2", qdd_ref),
    OUTPUT(vr_x_ref + 0, "x_ref.x", "tip reference x in the base frame at t + lookahead", "m",
           x_ref[0]),
    OUTPUT(vr_x_ref + 1, "x_ref.y", "tip reference y in the base frame at t + lookahead", "m",
           x_ref[1]),
    OUTPUT(vr_x_ref + 2, "x_ref.z", "tip reference z in the base frame (z0 up) at t + lookahead",
           "m", x_ref[2]),
    FMU_PARAM(vr_lookahead, "lookahead",
              "the outputs are the table at t + lookahead, in [0, 1]: one communication step "
              "compensates a master that gives the outputs of a step to the plant one step later",
              "s", T, lookahead),
    FMU_TIME_ROW(vr_time),
};

_Static_assert(sizeof reference_vars / sizeof reference_vars[0] == vr_count,
               "one table row per value reference");

/** Largest lookahead, s. */
#define REF_LOOKAHEAD_MAX 1.0
/** Longest line of the table, characters (19 numbers of 17 digits need about 470). */
#define REF_LINE_MAX 2048

/* The table read from resources/ (fmu_instance.work): n samples of REF_COLUMNS values. */
typedef struct reference_table {
    size_t n;
    uint64_t hash;
    double v[]; /* n * REF_COLUMNS, row-major */
} reference_table;

static reference_data *data_of(fmu_instance *inst)
{
    return (reference_data *)inst->data;
}

static fmu_status set_defaults(void *d)
{
    reference_data *r = d;
    memset(r, 0, sizeof *r);
    return FMU_OK;
}

static void release(fmu_instance *inst)
{
    if (inst->work != NULL) {
        inst->host.release(inst->work);
        inst->work = NULL;
    }
}

/* ---- the table reader ------------------------------------------------------------------------ */

/* One field of a line as a finite double in the C notation (digits, one '.', an exponent),
 * whatever LC_NUMERIC the importer's process set. 0 on success. */
static int parse_number(const char *s, size_t len, double *out)
{
    char buf[64];
    if (len == 0 || len >= sizeof buf) {
        return 1;
    }
    for (size_t i = 0; i < len; ++i) {
        const char c = s[i];
        if (!(isdigit((unsigned char)c) || c == '.' || c == 'e' || c == 'E' || c == '+' ||
              c == '-')) {
            return 1; /* also refuses nan, inf, hex floats and blanks */
        }
    }
    memcpy(buf, s, len);
    buf[len] = '\0';
    const char point = localeconv()->decimal_point[0];
    if (point != '.') {
        char *dot = strchr(buf, '.');
        if (dot != NULL) {
            *dot = point;
        }
    }
    char *end = NULL;
    errno = 0;
    const double v = strtod(buf, &end);
    if (end != buf + len || !isfinite(v) || (errno == ERANGE && fabs(v) > 1.0)) {
        return 1;
    }
    *out = v;
    return 0;
}

/* Strip a trailing LF and CR; 1 when the line had no LF (too long, or the last line). */
static int chomp(char *line, size_t *len)
{
    size_t n = strlen(line);
    const int had_lf = n > 0 && line[n - 1] == '\n';
    if (had_lf) {
        line[--n] = '\0';
    }
    if (n > 0 && line[n - 1] == '\r') {
        line[--n] = '\0';
    }
    *len = n;
    return !had_lf;
}

/* Check the header line against `columns`; 0 when it matches. */
static int check_header(fmu_instance *inst, const char *path, const char *line)
{
    const char *p = line;
    if ((unsigned char)p[0] == 0xEF && (unsigned char)p[1] == 0xBB &&
        (unsigned char)p[2] == 0xBF) {
        p += 3; /* a UTF-8 byte order mark */
    }
    for (int c = 0; c < REF_COLUMNS; ++c) {
        const size_t n = strlen(columns[c]);
        if (strncmp(p, columns[c], n) != 0 || (p[n] != ',' && p[n] != '\0') ||
            (c + 1 < REF_COLUMNS) != (p[n] == ',')) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: %s line 1: column %d must be \"%s\" (the header is t, q_ref[1..3], "
                    "qd_ref[1..3], qdd_ref[1..3], x_ref.x/y/z, xd_ref.x/y/z, xdd_ref.x/y/z: %d "
                    "columns), got \"%.60s\"",
                    FMU_FN(inst, "ExitInitializationMode"), path, c + 1, columns[c], REF_COLUMNS,
                    p);
            return 1;
        }
        p += n + (c + 1 < REF_COLUMNS ? 1 : 0);
    }
    return 0;
}

/* Parse data line `lineno` into row; 0 on success (otherwise logged). */
static int parse_row(fmu_instance *inst, const char *path, unsigned long lineno,
                     const char *line, double row[REF_COLUMNS])
{
    const char *fn = FMU_FN(inst, "ExitInitializationMode");
    const char *p = line;
    for (int c = 0; c < REF_COLUMNS; ++c) {
        const char *comma = strchr(p, ',');
        const size_t len = comma != NULL ? (size_t)(comma - p) : strlen(p);
        if (comma != NULL && c + 1 == REF_COLUMNS) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: %s line %lu has more than %d values", fn, path, lineno, REF_COLUMNS);
            return 1;
        }
        if (comma == NULL && c + 1 < REF_COLUMNS) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: %s line %lu has %d values, expected %d (columns t ... xdd_ref.z)", fn,
                    path, lineno, c + 1, REF_COLUMNS);
            return 1;
        }
        if (parse_number(p, len, &row[c]) != 0) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: %s line %lu, column %s: \"%.*s\" is not a finite decimal number", fn,
                    path, lineno, columns[c], (int)(len < 40 ? len : 40), p);
            return 1;
        }
        p += len + 1;
    }
    return 0;
}

/* Read and check the whole table; NULL after logging the reason. */
static reference_table *read_table(fmu_instance *inst)
{
    const char *fn = FMU_FN(inst, "ExitInitializationMode");
    if (inst->resources == NULL) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: no reference table: the importer passed no resource location that is a "
                "local folder (the table is resources/%s inside the FMU)",
                fn, REF_TABLE_FILE);
        return NULL;
    }
    const size_t plen = strlen(inst->resources) + sizeof REF_TABLE_FILE;
    char *path = inst->host.alloc(plen, 1);
    if (path == NULL) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: out of memory", fn);
        return NULL;
    }
    snprintf(path, plen, "%s%s", inst->resources, REF_TABLE_FILE);
    reference_table *table = NULL;
    char *line = inst->host.alloc(REF_LINE_MAX, 1);
    FILE *f = line != NULL ? fopen(path, "rb") : NULL;
    if (line == NULL) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: out of memory", fn);
        goto done;
    }
    if (f == NULL) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: cannot open the reference table %s: %s (the FMU needs resources/%s)", fn,
                path, strerror(errno), REF_TABLE_FILE);
        goto done;
    }
    /* pass 1: the header and the number of samples */
    unsigned long lineno = 0;
    size_t n = 0;
    size_t len = 0;
    while (fgets(line, REF_LINE_MAX, f) != NULL) {
        ++lineno;
        if (chomp(line, &len) && !feof(f)) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: %s line %lu is longer than %d characters",
                    fn, path, lineno, REF_LINE_MAX - 2);
            goto done;
        }
        if (lineno == 1) {
            if (check_header(inst, path, line) != 0) {
                goto done;
            }
            continue;
        }
        if (len == 0) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: %s line %lu is empty", fn, path,
                    lineno);
            goto done;
        }
        if (++n > REF_MAX_ROWS) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: %s has more than %u samples", fn, path,
                    REF_MAX_ROWS);
            goto done;
        }
    }
    if (ferror(f)) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: cannot read %s: %s", fn, path,
                strerror(errno));
        goto done;
    }
    if (lineno == 0) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: %s is empty (no header)", fn, path);
        goto done;
    }
    if (n < 2) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: %s has %zu sample(s): a reference needs at least 2", fn, path, n);
        goto done;
    }
    table = inst->host.alloc(1, sizeof *table + n * REF_COLUMNS * sizeof(double));
    if (table == NULL) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: out of memory (%zu samples)", fn, n);
        goto done;
    }
    table->n = n;
    /* pass 2: the values */
    rewind(f);
    lineno = 0;
    size_t k = 0;
    while (k < n && fgets(line, REF_LINE_MAX, f) != NULL) {
        ++lineno;
        chomp(line, &len);
        if (lineno == 1) {
            continue;
        }
        double *row = &table->v[k * REF_COLUMNS];
        if (parse_row(inst, path, lineno, line, row) != 0) {
            goto fail;
        }
        if (k > 0 && !(row[0] > row[-REF_COLUMNS])) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: %s line %lu: t = %.17g is not after t = %.17g of line %lu (times must "
                    "increase strictly)",
                    fn, path, lineno, row[0], row[-REF_COLUMNS], lineno - 1);
            goto fail;
        }
        ++k;
    }
    if (k != n) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: %s changed while it was read", fn, path);
        goto fail;
    }
    table->hash = fmu_fnv1a(FMU_FNV_OFFSET, table->v, n * REF_COLUMNS * sizeof(double)) | 1u;
    goto done;
fail:
    inst->host.release(table);
    table = NULL;
done:
    if (f != NULL) {
        fclose(f);
    }
    inst->host.release(line);
    inst->host.release(path);
    return table;
}

/* The table, read on first use (after instantiation, reset or a snapshot set into a fresh
 * instance); the model data must belong to it. */
static const reference_table *table_of(fmu_instance *inst)
{
    reference_data *r = data_of(inst);
    if (inst->work == NULL) {
        inst->work = read_table(inst);
        if (inst->work == NULL) {
            return NULL;
        }
    }
    const reference_table *table = inst->work;
    if (r->table_hash == 0) {
        r->table_hash = table->hash;
        r->cursor = 0;
    } else if (r->table_hash != table->hash) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state was taken with another reference table than resources/%s",
                MODEL_IDENTIFIER, REF_TABLE_FILE);
        return NULL;
    }
    return table;
}

/* ---- interpolation --------------------------------------------------------------------------- */

/* Position, velocity and acceleration at t0 + s h of the quintic through (p, v, a) at both ends
 * of an interval of length h: a[0..2] at t0, b[0..2] at t0 + h. With D = p1 - p0 the
 * polynomial is p0 + h v0 s + h^2 a0 s^2 / 2 + c3 s^3 + c4 s^4 + c5 s^5; the derivatives are
 * written so that s = 0 gives the sample exactly. */
static void hermite5(double h, double s, double p0, double v0, double a0, double p1, double v1,
                     double a1, double out[3])
{
    const double d = p1 - p0;
    const double hh = h * h;
    const double c3 = 10.0 * d - h * (6.0 * v0 + 4.0 * v1) - 0.5 * hh * (3.0 * a0 - a1);
    const double c4 = -15.0 * d + h * (8.0 * v0 + 7.0 * v1) + 0.5 * hh * (3.0 * a0 - 2.0 * a1);
    const double c5 = 6.0 * d - 3.0 * h * (v0 + v1) - 0.5 * hh * (a0 - a1);
    out[0] = p0 + s * (h * v0 + s * (0.5 * hh * a0 + s * (c3 + s * (c4 + s * c5))));
    out[1] = v0 + s * (hh * a0 + s * (3.0 * c3 + s * (4.0 * c4 + s * 5.0 * c5))) / h;
    out[2] = a0 + s * (6.0 * c3 + s * (12.0 * c4 + s * 20.0 * c5)) / hh;
}

/* The interval k (t_k <= t < t_k+1) of a time inside the table, starting at the cursor. */
static size_t find_interval(const reference_table *tb, size_t cursor, double t)
{
    const double *v = tb->v;
#define TIME(i) v[(i) * REF_COLUMNS]
    if (cursor >= tb->n) {
        cursor = 0; /* FMU states are checked (check_state): not reached */
    }
    if (cursor + 1 < tb->n && TIME(cursor) <= t && t < TIME(cursor + 1)) {
        return cursor;
    }
    if (cursor + 2 < tb->n && TIME(cursor + 1) <= t && t < TIME(cursor + 2)) {
        return cursor + 1;
    }
    size_t lo = 0;
    size_t hi = tb->n - 1; /* TIME(lo) <= t < TIME(hi) */
    while (hi - lo > 1) {
        const size_t mid = lo + (hi - lo) / 2;
        if (TIME(mid) <= t) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
#undef TIME
    return lo;
}

/* The outputs at table time t. */
static void evaluate(reference_data *r, const reference_table *tb, double t)
{
    const double *first = tb->v;
    const double *last = &tb->v[(tb->n - 1) * REF_COLUMNS];
    const double *hold = t < first[0] ? first : (t > last[0] ? last : NULL);
    double out[3];
    for (int j = 0; j < 2 * REF_NJ; ++j) {
        /* coordinate j: joint j (j < 3) or tip axis j - 3; its p, v, a columns */
        const int cp = j < REF_NJ ? 1 + j : 10 + (j - REF_NJ);
        const int cv = cp + 3;
        const int ca = cp + 6;
        if (hold != NULL) {
            out[0] = hold[cp];
            out[1] = 0.0;
            out[2] = 0.0;
        } else if (t == last[0]) {
            out[0] = last[cp];
            out[1] = last[cv];
            out[2] = last[ca];
        } else {
            const size_t k = find_interval(tb, (size_t)r->cursor, t);
            r->cursor = k;
            const double *a = &tb->v[k * REF_COLUMNS];
            const double *b = a + REF_COLUMNS;
            const double h = b[0] - a[0];
            hermite5(h, (t - a[0]) / h, a[cp], a[cv], a[ca], b[cp], b[cv], b[ca], out);
        }
        if (j < REF_NJ) {
            r->q_ref[j] = out[0];
            r->qd_ref[j] = out[1];
            r->qdd_ref[j] = out[2];
        } else {
            r->x_ref[j - REF_NJ] = out[0];
        }
    }
}

/* ---- hooks ----------------------------------------------------------------------------------- */

static fmu_status check_lookahead(fmu_instance *inst)
{
    const double l = data_of(inst)->lookahead;
    if (!(l >= 0.0 && l <= REF_LOOKAHEAD_MAX)) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: parameter lookahead must be in [0, %g] s, got %.17g",
                FMU_FN(inst, "ExitInitializationMode"), REF_LOOKAHEAD_MAX, l);
        return FMU_ERROR;
    }
    return FMU_OK;
}

static fmu_status initialize(fmu_instance *inst)
{
    if (check_lookahead(inst) != FMU_OK) {
        return FMU_ERROR;
    }
    const reference_table *tb = table_of(inst);
    if (tb == NULL) {
        return FMU_ERROR;
    }
    const double *ends[2] = {tb->v, &tb->v[(tb->n - 1) * REF_COLUMNS]};
    for (int e = 0; e < 2; ++e) {
        for (int c = 4; c < REF_COLUMNS; ++c) {
            if ((c < 10 || c >= 13) && ends[e][c] != 0.0) {
                fmu_log(inst, FMU_WARNING, FMU_LOG_WARNING,
                        "%s: the %s sample of resources/%s is not at rest (%s = %.17g): outside "
                        "[%.17g, %.17g] s the reference holds its end position at rest",
                        FMU_FN(inst, "ExitInitializationMode"), e == 0 ? "first" : "last",
                        REF_TABLE_FILE, columns[c], ends[e][c], tb->v[0], ends[1][0]);
                break;
            }
        }
    }
    return FMU_OK;
}

static fmu_status calculate(fmu_instance *inst)
{
    const reference_table *tb = table_of(inst);
    if (tb == NULL) {
        return FMU_ERROR;
    }
    reference_data *r = data_of(inst);
    evaluate(r, tb, inst->time + r->lookahead);
    return FMU_OK;
}

/* The outputs at the end of the step (the glue sets the time to t + h after this hook). */
static fmu_status do_step(fmu_instance *inst, double h)
{
    const reference_table *tb = table_of(inst);
    if (tb == NULL) {
        return FMU_ERROR;
    }
    reference_data *r = data_of(inst);
    evaluate(r, tb, inst->time + h + r->lookahead);
    return FMU_OK;
}

/* An FMU state's data (the glue has checked every table row finite): the look-up cursor is an
 * interval of the table the state was taken with (hash), which must be this instance's (read
 * now if it has not been yet); a state with no table (hash 0) has cursor 0; once initialized
 * the lookahead is in its range. Any other value is refused here, before a look-up could read
 * outside the table. */
static fmu_status check_state(fmu_instance *inst, const void *data, fmu_state state,
                              const char *fn)
{
    const reference_data *r = data;
    if (fmu_state_initialized(state) &&
        !(r->lookahead >= 0.0 && r->lookahead <= REF_LOOKAHEAD_MAX)) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds lookahead = %.17g s, outside [0, %g]", fn, r->lookahead,
                REF_LOOKAHEAD_MAX);
        return FMU_ERROR;
    }
    if (r->table_hash == 0) {
        if (r->cursor != 0) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: the FMU state holds the look-up cursor %llu but no reference table", fn,
                    (unsigned long long)r->cursor);
            return FMU_ERROR;
        }
        return FMU_OK;
    }
    if (inst->work == NULL) {
        inst->work = read_table(inst); /* logs why it cannot */
        if (inst->work == NULL) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: the FMU state was taken with a reference table, and this instance "
                    "cannot read resources/%s",
                    fn, REF_TABLE_FILE);
            return FMU_ERROR;
        }
    }
    const reference_table *tb = inst->work;
    if (r->table_hash != tb->hash) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state was taken with another reference table than resources/%s", fn,
                REF_TABLE_FILE);
        return FMU_ERROR;
    }
    if (r->cursor >= tb->n - 1) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds the look-up cursor %llu: the table has %zu samples, so "
                "the intervals are 0..%zu",
                fn, (unsigned long long)r->cursor, tb->n, tb->n - 2);
        return FMU_ERROR;
    }
    return FMU_OK;
}

/* The outputs depend on the time only (no inputs, no states). */
static int depends(fmu_vr unknown, fmu_vr known)
{
    (void)unknown;
    (void)known;
    return 0;
}

const fmu_model FMU_MODEL = {
    .identifier = MODEL_IDENTIFIER,
    .description = "Sampled joint and tip reference of the RRR arm, played from "
                   "resources/reference.csv with quintic Hermite interpolation (consistent q, qd, "
                   "qdd) and an optional look-ahead",
    .vars = reference_vars,
    .n_vars = sizeof reference_vars / sizeof reference_vars[0],
    .data_size = sizeof(reference_data),
    .default_stop_time = 1.0,
    .default_step_size = RRR_SAMPLE_TIME_DEFAULT,
    .default_tolerance = 1e-8,
    .set_defaults = set_defaults,
    .initialize = initialize,
    .calculate = calculate,
    .do_step = do_step,
    .depends = depends,
    .release = release,
    .check_state = check_state,
};
