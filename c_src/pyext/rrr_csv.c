/*
 * rrr_robot.core._csvfmt: the number formatting of the package's CSV writer
 * (rrr_robot.core.tables.write_csv) in C.
 *
 * format_rows(data) takes a 2-D C-contiguous buffer of native doubles (a float64 ndarray) and
 * returns its rows as CSV text: every value as printf's "%.17g" (17 significant digits: every
 * float64 read back exactly), values separated by ",", each row ended by "\n". NaN is written
 * "nan" whatever its sign bit (as Python's "%.17g" % x writes it; glibc would write "-nan"),
 * infinities "inf" and "-inf". The text is what the Python writer makes with
 * ("%.17g," * ...) % values, byte for byte (tests/python/test_tables.py compares them), in
 * about half the time: glibc's correctly rounded printf against CPython's; the GIL is released
 * while the rows are formatted.
 *
 * Without the Python headers the module is not built and write_csv formats in Python (same
 * bytes). Nor does it where the C locale's decimal point is not "." (a library called
 * setlocale(LC_NUMERIC, ...)): format_rows then returns None and write_csv formats in Python.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* the longest "%.17g" of a double: "-1.2345678901234567e-308" (24) */
#define RRR_CSV_MAX_VALUE 24

static size_t rrr_csv_value(char *out, double v)
{
    if (isnan(v)) {
        memcpy(out, "nan", 3);
        return 3;
    }
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
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t r = 0; r < rows; ++r) {
        const double *row = data + r * cols;
        for (Py_ssize_t c = 0; c < cols; ++c) {
            len += rrr_csv_value(buf + len, row[c]);
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
