/*
 * rrr_robot.core._csvfmt: the number formatting of the package's CSV writer
 * (rrr_robot.core.tables.write_csv) in C.
 *
 * format_rows(data) takes a 2-D C-contiguous buffer of native doubles (a float64 ndarray) and
 * returns its rows as CSV text: every value as printf's "%.17g" (17 significant digits: every
 * float64 read back exactly), values separated by ",", each row ended by "\n". NaN is written
 * "nan" whatever its sign bit (as Python's "%.17g" % x writes it; glibc would write "-nan"),
 * infinities "inf" and "-inf". The text is what the Python writer makes with
 * ("%.17g," * ...) % values, byte for byte (tests/python/test_tables.py compares them), about
 * 6x faster (8.5 ms against 57 ms for the 5,909 x 31 values of a writing scenario's table); the
 * GIL is released while the rows are formatted.
 *
 * The values of a signal table (1e-11 <= |v| < 1e43, and 0) are formatted without printf: the
 * 17 significant digits are the integer nearest to |v| * 10^(16 - e), where
 * 10^e <= |v| < 10^(e+1), computed in a long double of at least 64 significant bits (x87
 * extended precision on x86; 10^k is exact for k <= 27, so the product or quotient is within
 * 2^-64 of the exact one: at most 0.006 at the 17-digit integer's scale). Where that error
 * could change the result (the product within 0.01 of a rounding tie, or within 1 of the 16-
 * or 17-digit bounds) and for every other value, snprintf formats it. The text is snprintf's in
 * every case (tests/python/test_tables.py compares them on about a million values), about 3.5x
 * faster than glibc's snprintf (60 against 210 ns a value). Without 64 significant bits
 * (LDBL_MANT_DIG < 64, e.g. MSVC's long double, which is a double), or when the x87 precision
 * control was set to double at run time (rrr_csv_extended), every value goes to snprintf.
 *
 * Without the Python headers the module is not built and write_csv formats in Python (same
 * bytes). Nor does it where the C locale's decimal point is not "." (a library called
 * setlocale(LC_NUMERIC, ...)): format_rows then returns None and write_csv formats in Python.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <float.h>
#include <locale.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* the longest "%.17g" of a double: "-1.2345678901234567e-308" (24) */
#define RRR_CSV_MAX_VALUE 24

#if LDBL_MANT_DIG >= 64
#define RRR_CSV_FAST 1
/* 10^k, k = 0..27: exact in a 64-bit significand (5^27 < 2^63) */
static const long double rrr_csv_pow10[28] = {
    1e0L,  1e1L,  1e2L,  1e3L,  1e4L,  1e5L,  1e6L,  1e7L,  1e8L,  1e9L,
    1e10L, 1e11L, 1e12L, 1e13L, 1e14L, 1e15L, 1e16L, 1e17L, 1e18L, 1e19L,
    1e20L, 1e21L, 1e22L, 1e23L, 1e24L, 1e25L, 1e26L, 1e27L,
};

/* |v| * 10^p, p in [-27, 27], one rounding in long double */
static long double rrr_csv_scaled(double a, int p)
{
    return p >= 0 ? (long double)a * rrr_csv_pow10[p] : (long double)a / rrr_csv_pow10[-p];
}

/* whether long double arithmetic has its 64-bit significand here (not an x87 precision control
 * set to double by some library): else the error bound above does not hold */
static int rrr_csv_extended(void)
{
    volatile long double one = 1.0L, tiny = 0x1p-63L;
    return one + tiny != one;
}

/* "%.17g" of v without printf where that is exact (see the file's comment): the length, or 0
 * when snprintf has to format it */
static size_t rrr_csv_fast(char *out, double v)
{
    if (v == 0.0) {
        if (signbit(v)) {
            memcpy(out, "-0", 2);
            return 2;
        }
        out[0] = '0';
        return 1;
    }
    const double a = fabs(v);
    if (!(a >= 1e-11 && a < 1e43)) {
        return 0; /* also inf */
    }
    int e2;
    (void)frexp(a, &e2); /* 2^(e2-1) <= a < 2^e2 */
    /* e = floor((e2 - 1) log10 2) (78913 / 2^18 for log10 2; e2 is -36 to 143 here): the
     * decimal exponent of a or one less, corrected below (the range check after it catches any
     * other miss: the result never depends on this estimate) */
    const int m = (e2 - 1) * 78913;
    int e = m >= 0 ? m >> 18 : -((-m + 262143) >> 18);
    if (16 - e > 27 || 16 - e < -26) {
        return 0; /* 10^(16 - e) and 10^(17 - e) or 10^(15 - e) must be in the table */
    }
    long double y = rrr_csv_scaled(a, 16 - e);
    if (y < 1e16L) {
        if (16 - e == 27) {
            return 0;
        }
        --e;
        y = rrr_csv_scaled(a, 16 - e);
    } else if (y >= 1e17L) {
        ++e;
        y = rrr_csv_scaled(a, 16 - e);
    }
    if (!(y >= 1e16L + 1.0L && y < 1e17L - 1.0L)) {
        return 0;
    }
    uint64_t n = (uint64_t)y; /* y > 0: its floor */
    const long double frac = y - (long double)n; /* exact: y < 2^57 */
    if (fabsl(frac - 0.5L) < 0.01L) {
        return 0; /* near a tie: the error of y could decide it */
    }
    n += frac > 0.5L;
    char d[18]; /* the 17 significant digits (d[0] to d[16]), two at a time */
    for (int i = 16; i > 0; i -= 2) {
        const unsigned pair = (unsigned)(n % 100u);
        n /= 100u;
        d[i] = (char)('0' + pair % 10u);
        d[i - 1] = (char)('0' + pair / 10u);
    }
    d[0] = (char)('0' + n);
    int last = 16; /* the last digit kept: "%g" drops trailing zeros */
    while (last > 0 && d[last] == '0') {
        --last;
    }
    size_t len = 0;
    if (v < 0.0) {
        out[len++] = '-';
    }
    if (e >= -4 && e < 17) { /* fixed notation, 16 - e decimals */
        if (e >= 0) {
            memcpy(out + len, d, (size_t)e + 1);
            len += (size_t)e + 1;
            if (last > e) {
                out[len++] = '.';
                memcpy(out + len, d + e + 1, (size_t)(last - e));
                len += (size_t)(last - e);
            }
        } else {
            out[len++] = '0';
            out[len++] = '.';
            for (int i = 0; i < -e - 1; ++i) {
                out[len++] = '0';
            }
            memcpy(out + len, d, (size_t)last + 1);
            len += (size_t)last + 1;
        }
    } else { /* exponent notation: d.ddde+XX */
        out[len++] = d[0];
        if (last > 0) {
            out[len++] = '.';
            memcpy(out + len, d + 1, (size_t)last);
            len += (size_t)last;
        }
        out[len++] = 'e';
        out[len++] = e < 0 ? '-' : '+';
        const int x = e < 0 ? -e : e; /* 5 to 42 here */
        out[len++] = (char)('0' + x / 10);
        out[len++] = (char)('0' + x % 10);
    }
    return len;
}
#endif

static size_t rrr_csv_value(char *out, double v, int extended)
{
    if (isnan(v)) {
        memcpy(out, "nan", 3);
        return 3;
    }
#ifdef RRR_CSV_FAST
    const size_t fast = extended ? rrr_csv_fast(out, v) : 0;
    if (fast > 0) {
        return fast;
    }
#else
    (void)extended;
#endif
    int n = snprintf(out, RRR_CSV_MAX_VALUE + 1, "%.17g", v);
    return n > 0 ? (size_t)n : 0;
}

static PyObject *format_rows(PyObject *self, PyObject *arg)
{
    (void)self;
    Py_buffer view;
    if (PyObject_GetBuffer(arg, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_ND) != 0) {
        return NULL;
    }
    if (view.ndim != 2 || view.itemsize != (Py_ssize_t)sizeof(double) || view.format == NULL ||
        (strcmp(view.format, "d") != 0 && strcmp(view.format, "<d") != 0 &&
         strcmp(view.format, "=d") != 0)) {
        PyBuffer_Release(&view);
        PyErr_SetString(PyExc_TypeError,
                        "format_rows: a 2-D C-contiguous buffer of native doubles expected");
        return NULL;
    }
    const struct lconv *lc = localeconv();
    if (lc == NULL || lc->decimal_point == NULL || strcmp(lc->decimal_point, ".") != 0) {
        PyBuffer_Release(&view);
        Py_RETURN_NONE; /* printf would not write what Python writes */
    }
    const Py_ssize_t rows = view.shape[0], cols = view.shape[1];
    if (rows == 0 || cols == 0) {
        PyBuffer_Release(&view);
        return PyUnicode_FromStringAndSize("", 0);
    }
    /* each value at most RRR_CSV_MAX_VALUE characters and its separator */
    if (rows > PY_SSIZE_T_MAX / cols / (RRR_CSV_MAX_VALUE + 1)) {
        PyBuffer_Release(&view);
        return PyErr_NoMemory();
    }
    const size_t cap = (size_t)rows * (size_t)cols * (RRR_CSV_MAX_VALUE + 1);
    char *buf = PyMem_RawMalloc(cap);
    if (buf == NULL) {
        PyBuffer_Release(&view);
        return PyErr_NoMemory();
    }
    const double *data = view.buf;
    size_t len = 0;
#ifdef RRR_CSV_FAST
    const int extended = rrr_csv_extended();
#else
    const int extended = 0;
#endif
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t r = 0; r < rows; ++r) {
        const double *row = data + r * cols;
        for (Py_ssize_t c = 0; c < cols; ++c) {
            len += rrr_csv_value(buf + len, row[c], extended);
            buf[len++] = c + 1 < cols ? ',' : '\n';
        }
    }
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&view);
    PyObject *text = PyUnicode_DecodeASCII(buf, (Py_ssize_t)len, "strict");
    PyMem_RawFree(buf);
    return text;
}

static PyMethodDef csv_methods[] = {
    {"format_rows", format_rows, METH_O,
     "format_rows(data): the rows of a 2-D C-contiguous float64 array as CSV text, every value "
     "as '%.17g' (NaN as 'nan'), ',' between values, '\\n' after each row; None where the C "
     "locale's decimal point is not '.'."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef csv_module = {
    PyModuleDef_HEAD_INIT,
    .m_name = "rrr_robot.core._csvfmt",
    .m_doc = "The number formatting of rrr_robot.core.tables.write_csv in C.",
    .m_size = 0,
    .m_methods = csv_methods,
};

PyMODINIT_FUNC PyInit__csvfmt(void);

PyMODINIT_FUNC PyInit__csvfmt(void)
{
    return PyModule_Create(&csv_module);
}
