/* The reference table of the bench's controller (hil_reference.h). */
#include "hil_reference.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hil_common.h" /* RRR_HIL_PERIOD_S */

/* The columns the controller needs, in the order of rrr_hil_reference_load's v[]: found in the
 * table's header by name (the reference FMU's table has 19 columns, the tip ones unused here). */
static const char *const REF_NEEDED[RRR_HIL_REF_NEEDED] = {
    "t",          "q_ref[1]",   "q_ref[2]",   "q_ref[3]",   "qd_ref[1]",
    "qd_ref[2]",  "qd_ref[3]",  "qdd_ref[1]", "qdd_ref[2]", "qdd_ref[3]"};

void rrr_hil_reference_free(rrr_hil_reference *r)
{
    free(r->t);
    free(r->q);
    free(r->qd);
    free(r->qdd);
    memset(r, 0, sizeof *r);
}

static int grow(rrr_hil_reference *r, size_t cap)
{
    double *t = realloc(r->t, cap * sizeof *r->t);
    if (t != NULL) {
        r->t = t;
    }
    double(*q)[3] = realloc(r->q, cap * sizeof *r->q);
    if (q != NULL) {
        r->q = q;
    }
    double(*qd)[3] = realloc(r->qd, cap * sizeof *r->qd);
    if (qd != NULL) {
        r->qd = qd;
    }
    double(*qdd)[3] = realloc(r->qdd, cap * sizeof *r->qdd);
    if (qdd != NULL) {
        r->qdd = qdd;
    }
    return (t && q && qd && qdd) ? 0 : -1;
}

/* Split the header line into at most RRR_HIL_REF_MAX_COLUMNS names (in place); the count, or -1
 * with a message. */
static int split_header(char *line, char **names, const char *path, char *err, size_t err_len)
{
    line[strcspn(line, "\r\n")] = '\0';
    int n = 0;
    for (char *p = line;; ++n) {
        if (n == RRR_HIL_REF_MAX_COLUMNS) {
            snprintf(err, err_len, "%s:1: more than %d columns", path, RRR_HIL_REF_MAX_COLUMNS);
            return -1;
        }
        names[n] = p;
        char *comma = strchr(p, ',');
        if (comma == NULL) {
            return n + 1;
        }
        *comma = '\0';
        p = comma + 1;
    }
}

/* The index in the header of each needed column; 0, or -1 naming the one missing or repeated. */
static int find_columns(char **names, int n, int *col, const char *path, char *err,
                        size_t err_len)
{
    for (int j = 0; j < RRR_HIL_REF_NEEDED; ++j) {
        col[j] = -1;
        for (int c = 0; c < n; ++c) {
            if (strcmp(names[c], REF_NEEDED[j]) != 0) {
                continue;
            }
            if (col[j] >= 0) {
                snprintf(err, err_len, "%s:1: the column '%s' appears twice", path,
                         REF_NEEDED[j]);
                return -1;
            }
            col[j] = c;
        }
        if (col[j] < 0) {
            snprintf(err, err_len,
                     "%s:1: the reference table has no column '%s' (it needs t, q_ref[1..3], "
                     "qd_ref[1..3] and qdd_ref[1..3]: the reference FMU's table, written by "
                     "rrr hil export-reference)",
                     path, REF_NEEDED[j]);
            return -1;
        }
    }
    return 0;
}

/* Parse one row of n finite numbers into v; 0, or -1 naming the column. */
static int parse_row(const char *line, int n, char **names, double *v, const char *path,
                     long lineno, char *err, size_t err_len)
{
    const char *p = line;
    for (int c = 0; c < n; ++c) {
        char *end;
        v[c] = strtod(p, &end);
        const int last = c + 1 == n;
        const int sep_ok = last ? (*end == '\n' || *end == '\0' || *end == '\r') : *end == ',';
        if (end == p || !isfinite(v[c]) || !sep_ok) {
            if (!last && (*end == '\n' || *end == '\0' || *end == '\r') && end != p) {
                snprintf(err, err_len, "%s:%ld: %d values, the header has %d columns", path,
                         lineno, c + 1, n);
            } else if (last && *end == ',') {
                snprintf(err, err_len, "%s:%ld: more values than the header's %d columns", path,
                         lineno, n);
            } else {
                snprintf(err, err_len, "%s:%ld: column %d (%s) is not a finite number", path,
                         lineno, c + 1, names[c]);
            }
            return -1;
        }
        p = end + 1;
    }
    return 0;
}

int rrr_hil_reference_load(const char *path, rrr_hil_reference *r, char *err, size_t err_len)
{
    memset(r, 0, sizeof *r);
    FILE *fp = fopen(path, "r");
    if (fp == NULL) {
        snprintf(err, err_len, "cannot open reference %s: %s", path, strerror(errno));
        return -1;
    }
    char header[RRR_HIL_REF_LINE_MAX];
    char line[RRR_HIL_REF_LINE_MAX];
    char *names[RRR_HIL_REF_MAX_COLUMNS];
    int col[RRR_HIL_REF_NEEDED];
    double v[RRR_HIL_REF_MAX_COLUMNS];
    size_t cap = 0;
    long lineno = 1;
    int rc = 0;
    int n_cols = 0;
    if (fgets(header, sizeof header, fp) == NULL) {
        snprintf(err, err_len, "%s:1: empty (expected a header naming the columns)", path);
        rc = -1;
    } else if (strchr(header, '\n') == NULL && !feof(fp)) {
        snprintf(err, err_len, "%s:1: the header is longer than %d characters", path,
                 RRR_HIL_REF_LINE_MAX - 2);
        rc = -1;
    } else {
        n_cols = split_header(header, names, path, err, err_len);
        rc = n_cols < 0 ? -1 : find_columns(names, n_cols, col, path, err, err_len);
    }
    while (rc == 0 && fgets(line, sizeof line, fp) != NULL) {
        ++lineno;
        if (strchr(line, '\n') == NULL && !feof(fp)) {
            snprintf(err, err_len, "%s:%ld: longer than %d characters", path, lineno,
                     RRR_HIL_REF_LINE_MAX - 2);
            rc = -1;
            break;
        }
        if (line[0] == '\n' || line[0] == '\0' || (line[0] == '\r' && line[1] == '\n')) {
            continue;
        }
        if (r->n == cap) {
            cap = cap ? 2u * cap : 4096u;
            if (grow(r, cap) != 0) {
                snprintf(err, err_len, "%s: out of memory at line %ld", path, lineno);
                rc = -1;
                break;
            }
        }
        if (parse_row(line, n_cols, names, v, path, lineno, err, err_len) != 0) {
            rc = -1;
            break;
        }
        const size_t k = r->n;
        r->t[k] = v[col[0]];
        for (int j = 0; j < 3; ++j) {
            r->q[k][j] = v[col[1 + j]];
            r->qd[k][j] = v[col[4 + j]];
            r->qdd[k][j] = v[col[7 + j]];
        }
        if (k > 0u && fabs(r->t[k] - r->t[k - 1u] - RRR_HIL_PERIOD_S) > 1e-6 * RRR_HIL_PERIOD_S) {
            snprintf(err, err_len, "%s:%ld: t steps by %.17g s; the bench needs %.17g s", path,
                     lineno, r->t[k] - r->t[k - 1u], RRR_HIL_PERIOD_S);
            rc = -1;
        }
        ++r->n;
    }
    fclose(fp);
    if (rc == 0 && r->n < 2u) {
        snprintf(err, err_len, "%s: needs at least two samples", path);
        rc = -1;
    }
    if (rc != 0) {
        rrr_hil_reference_free(r);
    }
    return rc;
}
