/* Model: defaults validate, eq 12 from inertial parameters, validation names the bad field. */
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_test.h"

static void test_default(void)
{
    rrr_model m;
    CHECK_STATUS(rrr_model_default(&m), RRR_OK);
    const char *field = NULL;
    CHECK_STATUS(rrr_model_validate(&m, &field), RRR_OK);
    CHECK(field != NULL && field[0] == '\0');
    CHECK_CLOSE(m.a2, 0.40, 0.0);
    CHECK_CLOSE(m.d2 + m.d3, 0.10, 1e-15);
    CHECK(m.kt[0] > 0.0 && m.kt[1] > 0.0 && m.kt[2] > 0.0);
    CHECK_STATUS(rrr_model_default(NULL), RRR_BAD_INPUT);
}

/* A point mass on link 3 only: p13 is its inertia about the joint-3 axis, p3 and p4 its
 * first moments about that axis, p14 - p13 the rotor inertia. */
static void test_bps_point_mass(void)
{
    rrr_model m;
    rrr_model_default(&m);
    rrr_inertial in;
    memset(&in, 0, sizeof in);
    const double m3 = 1.7, x3 = -0.12, y3 = 0.03, z3 = 0.04;
    in.link[2].mass = m3;
    in.link[2].com[0] = x3;
    in.link[2].com[1] = y3;
    in.link[2].com[2] = z3;
    in.rotor_inertia[2] = 0.013;
    double p[RRR_NP];
    CHECK_STATUS(rrr_bps_from_inertia(&m, &in, p), RRR_OK);
    const double a3 = m.a3, a2 = m.a2, e = m.d2 + m.d3;
    CHECK_CLOSE(p[12], m3 * ((a3 + x3) * (a3 + x3) + y3 * y3), 1e-15);
    CHECK_CLOSE(p[13] - p[12], 0.013, 1e-15);
    CHECK_CLOSE(p[2], m3 * (a3 + x3), 1e-15);
    CHECK_CLOSE(p[3], m3 * y3, 1e-15);
    CHECK_CLOSE(p[14], m3 * a2, 1e-15);
    CHECK_CLOSE(p[15], 0.0, 0.0);
    /* p7: inertia about the vertical axis at q = 0 of the point at (a2 + a3 + x3, e + z3) in
     * the horizontal plane, minus the parts that vary with q2, q3 (p1, p5, p12 terms) */
    const double izz_o = m3 * (x3 * x3 + y3 * y3);
    CHECK_CLOSE(p[6], 2.0 * e * m3 * z3 + e * e * m3 + m3 * (y3 * y3 + z3 * z3), 1e-15);
    CHECK_CLOSE(p[11], (a2 * a2 + a3 * a3 + 2.0 * a3 * x3) * m3 + izz_o, 1e-15);
}

static void test_bps_bad(void)
{
    rrr_model m;
    rrr_model_default(&m);
    rrr_inertial in;
    rrr_inertial_default(&in);
    double p[RRR_NP];
    for (int i = 0; i < RRR_NP; ++i) {
        p[i] = 42.0;
    }
    rrr_inertial bad = in;
    bad.link[1].mass = -1.0;
    CHECK_STATUS(rrr_bps_from_inertia(&m, &bad, p), RRR_BAD_INPUT);
    bad = in;
    bad.link[2].inertia_com[0][1] = (double)NAN;
    CHECK_STATUS(rrr_bps_from_inertia(&m, &bad, p), RRR_BAD_INPUT);
    bad = in;
    bad.rotor_inertia[0] = (double)INFINITY;
    CHECK_STATUS(rrr_bps_from_inertia(&m, &bad, p), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_bps_from_inertia(NULL, &in, p), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_bps_from_inertia(&m, NULL, p), RRR_BAD_INPUT);
    for (int i = 0; i < RRR_NP; ++i) {
        CHECK(p[i] == 42.0);
    }
}

static void expect_invalid(const rrr_model *m, rrr_status st, const char *name)
{
    const char *field = NULL;
    CHECK_STATUS(rrr_model_validate(m, &field), st);
    CHECK(field != NULL && strcmp(field, name) == 0);
    if (field != NULL && strcmp(field, name) != 0) {
        fprintf(stderr, "  field was %s, expected %s\n", field, name);
    }
}

static void test_validate(void)
{
    rrr_model ok;
    rrr_model_default(&ok);
    rrr_model m = ok;
    m.kt[1] = 0.0;
    expect_invalid(&m, RRR_BAD_MODEL, "kt[2]");
    m = ok;
    m.kt[2] = -3.0;
    expect_invalid(&m, RRR_BAD_MODEL, "kt[3]");
    m = ok;
    m.p[4] = (double)NAN;
    expect_invalid(&m, RRR_BAD_MODEL, "p[5]");
    m = ok;
    m.a3 = 0.0;
    expect_invalid(&m, RRR_BAD_MODEL, "a3");
    m = ok;
    m.d1 = (double)INFINITY;
    expect_invalid(&m, RRR_BAD_MODEL, "d1");
    m = ok;
    m.u_max = 0.0;
    expect_invalid(&m, RRR_BAD_MODEL, "u_max");
    m = ok;
    m.f[2][1] = (double)NAN;
    expect_invalid(&m, RRR_BAD_MODEL, "f[3,2]");
    m = ok;
    m.w[0][0] = -1.0;
    expect_invalid(&m, RRR_BAD_MODEL, "w[1,1]");
    m = ok;
    m.b[0] = -0.1;
    expect_invalid(&m, RRR_BAD_MODEL, "b[1]");
    m = ok;
    memset(m.p, 0, sizeof m.p);
    expect_invalid(&m, RRR_NOT_POSITIVE_DEFINITE, "p");
    m = ok;
    m.p[13] = -1.0; /* D33 = p14 < 0 */
    expect_invalid(&m, RRR_NOT_POSITIVE_DEFINITE, "p");
    /* D(q) loses positive definiteness only in a thin dip between the points of a 64 x 64 grid
     * (found by a review: smallest eigenvalue -4.2e-4 at q2 = -pi/2, q3 = -3.0910); the
     * pattern search from the grid minima must catch it */
    static const double dip[RRR_NP] = {0.72, -0.0, 0.49939772810258615, -0.02453383716370898,
                                       0.125, 0.0, 0.521, 0.0, -0.06, 0.0, -0.36,
                                       0.5816198099497684, 0.13, 0.14, 2.2, 0.0};
    m = ok;
    memcpy(m.p, dip, sizeof dip);
    expect_invalid(&m, RRR_NOT_POSITIVE_DEFINITE, "p");
    double Dd[3][3];
    const double q_dip[3] = {0.0, -1.5707963, -3.0910};
    CHECK_STATUS(rrr_mass_matrix(&m, q_dip, Dd), RRR_OK);
    CHECK(Dd[0][0] * Dd[1][1] - Dd[0][1] * Dd[1][0] < 0.0 || Dd[0][0] <= 0.0 ||
          Dd[0][0] * (Dd[1][1] * Dd[2][2] - Dd[1][2] * Dd[2][1]) -
                  Dd[0][1] * (Dd[1][0] * Dd[2][2] - Dd[1][2] * Dd[2][0]) +
                  Dd[0][2] * (Dd[1][0] * Dd[2][1] - Dd[1][1] * Dd[2][0]) <
              0.0); /* there D really is indefinite */
    m.p[11] += 1e-3; /* a little more I_zz lifts the dip: valid again */
    CHECK_STATUS(rrr_model_validate(&m, NULL), RRR_OK);
    CHECK_STATUS(rrr_model_validate(NULL, NULL), RRR_BAD_INPUT);
    CHECK(strcmp(rrr_status_str(RRR_UNREACHABLE), "RRR_UNREACHABLE") == 0);
    CHECK(strcmp(rrr_status_str((rrr_status)99), "RRR_UNKNOWN_STATUS") == 0);
    /* the library reports the version of the header it was built from */
    CHECK(strcmp(rrr_version(), RRR_VERSION_STRING) == 0);
}

/* The parameter table: one row per scalar of rrr_model, in the struct's order (the FMUs derive
 * their value references from it), names and ranges that lookup, get/set and validation share. */
static void test_param_table(void)
{
    size_t n = 0;
    const rrr_param_info *t = rrr_param_table(&n);
    CHECK(n == RRR_N_PARAMS && sizeof(rrr_model) == RRR_N_PARAMS * sizeof(double));
    for (size_t i = 0; i < n; ++i) {
        CHECK(t[i].offset == i * sizeof(double));
        CHECK(rrr_param_index(t[i].name) == (int)i);
        CHECK(strlen(t[i].description) > 10 && strlen(t[i].unit) > 0);
    }
    CHECK(strcmp(t[0].name, "d1") == 0 && strcmp(t[6].name, "p[1]") == 0);
    CHECK(strcmp(t[21].name, "p[16]") == 0 && strcmp(t[22].name, "kt[1]") == 0);
    CHECK(strcmp(t[25].name, "f[1,1]") == 0 && strcmp(t[33].name, "f[3,3]") == 0);
    CHECK(strcmp(t[34].name, "w[1,1]") == 0 && strcmp(t[43].name, "b[1]") == 0);
    CHECK(strcmp(t[46].name, "u_max") == 0);
    CHECK(rrr_param_index("p[17]") == -1 && rrr_param_index("p") == -1);
    CHECK(rrr_param_index(NULL) == -1 && rrr_param_index("") == -1);

    rrr_model m;
    CHECK(rrr_model_default(&m) == RRR_OK);
    const int f23 = rrr_param_index("f[2,3]");
    CHECK(f23 >= 0 && rrr_param_get(&m, (size_t)f23) == m.f[1][2]);
    CHECK(rrr_param_set(&m, (size_t)f23, 0.125) == RRR_OK && m.f[1][2] == 0.125);
    CHECK(rrr_param_set(&m, (size_t)f23, (double)NAN) == RRR_BAD_INPUT && m.f[1][2] == 0.125);
    CHECK(rrr_param_set(&m, n, 1.0) == RRR_BAD_INPUT && rrr_param_set(NULL, 0, 1.0) == RRR_BAD_INPUT);
    CHECK(isnan(rrr_param_get(&m, n)) && isnan(rrr_param_get(NULL, 0)));

    const int a2 = rrr_param_index("a2"), g = rrr_param_index("g"), d1 = rrr_param_index("d1");
    CHECK(!rrr_param_in_range((size_t)a2, 0.0) && rrr_param_in_range((size_t)a2, 1e-9));
    CHECK(rrr_param_in_range((size_t)g, 0.0) && !rrr_param_in_range((size_t)g, -1e-9));
    CHECK(rrr_param_in_range((size_t)d1, -5.0) && !rrr_param_in_range((size_t)d1, (double)INFINITY));
    /* validation names the row, for every row */
    for (size_t i = 0; i < n; ++i) {
        rrr_model bad = m;
        const char *field = NULL;
        memcpy((char *)&bad + t[i].offset, &(double){(double)NAN}, sizeof(double));
        CHECK(rrr_model_validate(&bad, &field) == RRR_BAD_MODEL);
        CHECK(field != NULL && strcmp(field, t[i].name) == 0);
    }
}

int main(void)
{
    test_default();
    test_bps_point_mass();
    test_bps_bad();
    test_validate();
    test_param_table();
    return rrr_test_report("test_model");
}
