/*
 * rrr_robot.core._ext: the compiled CPython binding of librrr, the one way Python reaches it.
 *
 * It converts arguments and loops over rows; every number comes from a librrr call (linked
 * statically from the same objects as the package's librrr.so), never from model maths here.
 *
 * - Kernels(raw): holds a RawModel (a ctypes struct used as plain memory: kept alive, its buffer
 *   exported for the Kernels' life) and reads the rrr_model in place, so the Model's parameters
 *   have one home. Its methods are Model's calls and the plant step (rr.Plant).
 * - Module functions: the rest of librrr that Python uses (defaults, validation, base
 *   parameters, the parameter table, the integrator's check, the stiffness, the version, the
 *   batch paths, the closed loop in parts), on the ctypes structs of rrr_robot.core._lib through
 *   their buffers, checked by size (SIZES).
 * - Arguments are (3,) vectors or (n, 3) batches with the rules of rrr_robot.core._arrays:
 *   any buffer of C-contiguous aligned native doubles (a float64 ndarray, array.array,
 *   memoryview, ctypes arrays) is read in place (no copy); a list or tuple of three floats or
 *   ints is read directly; anything else goes through _arrays.as_rows, which converts it or
 *   raises the package's BadInputError with its message. Batches broadcast single rows: an
 *   argument of one row is repeated against (n, 3) others; other row counts are refused.
 * - Results are new float64 numpy arrays, made by numpy.empty and written through the buffer
 *   protocol. No numpy header or C API is used, and only CPython's limited API (3.11, where the
 *   buffer protocol joined it): with Py_LIMITED_API the module is one abi3 binary for every
 *   CPython from 3.11 on.
 * - Every row is checked by the status of its C call; a failure raises the exception class of
 *   rrr_robot.core._status for that status, with the row named
 *   ("rrr_fk failed with RRR_BAD_INPUT (...): sample 4: q = [0.1, nan, 0.3]").
 * - Batches of at least RRR_EXT_NOGIL_ROWS rows run without the GIL (the loop touches no Python
 *   object; a failing row is reported after the GIL is taken back), as do the batch kernels,
 *   the rollout and the closed loop.
 *
 * Adding a call of librrr: a row function with the row_fn signature and a map_spec naming its
 * inputs and outputs; map_rows() does the rest (parsing, broadcasting, the GIL, the error
 * message). ctc is the model for a call with a parameter block besides the rows.
 *
 * The closed loop: the control law (Kernels.ctc, Model.ctc; row_ctc is one sample of it) and
 * the plant step (Kernels.plant_step, plant_accel, plant_rollout: rrr_plant_step,
 * rrr_plant_accel and rrr_plant_rollout on an rrr_plant_state held in a ctypes struct that the
 * call updates; rr.Plant). The whole loop in C is sim_closed_loop_part (rr.simulate).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rrr/rrr.h"

#define NJ 3
#define MAX_IN 5
#define MAX_OUT 3

/* The few helpers of every one-state call, inlined into it (GCC and Clang). */
#if defined(__GNUC__)
#define HOT_INLINE __attribute__((always_inline)) inline
#else
#define HOT_INLINE inline
#endif
/** Batches of at least this many rows release the GIL while they run. */
#define RRR_EXT_NOGIL_ROWS 1000

/* ------------------------------------------------------------------------------------------ */
/* Results: numpy arrays through numpy.empty and the buffer protocol                           */
/* ------------------------------------------------------------------------------------------ */

static PyObject *g_empty;         /* numpy.empty */

/* rrr_robot */
static PyObject *g_as_rows;       /* rrr_robot.core._arrays.as_rows */
static PyObject *g_rrr_error;     /* rrr_robot.errors.RrrError */
static PyObject *g_bad_input;     /* rrr_robot.errors.BadInputError */
static PyObject *g_status_names;  /* rrr_robot.core._status.STATUS_NAMES (tuple) */
static PyObject *g_status_errors; /* rrr_robot.core._status.ERRORS (dict: status -> class) */
static PyObject *g_status_meaning;/* rrr_robot.core._status.MEANING (dict: status -> str) */
static PyObject *g_branch_names;  /* tuple of the four (shoulder, elbow) name tuples */
static PyObject *g_simd_names[RRR_SIMD_AVX512 + 1]; /* interned "auto" ... "avx512" by value */

/* The arguments of numpy.empty for the shapes of one state's results, made once: (shape,). */
#define SHAPE_CACHE 16
static struct {
    int rank;
    Py_ssize_t dims[4];
    PyObject *args;
} g_shapes[SHAPE_CACHE];
static int g_n_shapes;

/* The data of a new array of ours (writable, C-contiguous): the pointer stays valid while the
 * array lives, since it owns its memory. */
static double *array_data(PyObject *arr)
{
    Py_buffer view;
    if (PyObject_GetBuffer(arr, &view, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) != 0) {
        return NULL;
    }
    double *data = (double *)view.buf;
    PyBuffer_Release(&view);
    return data;
}

/* The argument tuple (shape,) of numpy.empty: new, or borrowed from the cache (*owned = 0). */
static PyObject *shape_args(int rank, const Py_ssize_t *shape, int cache, int *owned)
{
    for (int k = 0; cache && k < g_n_shapes; ++k) {
        if (g_shapes[k].rank == rank &&
            memcmp(g_shapes[k].dims, shape, (size_t)rank * sizeof *shape) == 0) {
            *owned = 0;
            return g_shapes[k].args;
        }
    }
    PyObject *tuple = PyTuple_New(rank);
    if (tuple == NULL) {
        return NULL;
    }
    for (int k = 0; k < rank; ++k) {
        PyObject *v = PyLong_FromSsize_t(shape[k]);
        if (v == NULL || PyTuple_SetItem(tuple, k, v) != 0) { /* steals v */
            Py_DECREF(tuple);
            return NULL;
        }
    }
    PyObject *args = PyTuple_Pack(1, tuple);
    Py_DECREF(tuple);
    if (args == NULL) {
        return NULL;
    }
    if (cache && g_n_shapes < SHAPE_CACHE) {
        g_shapes[g_n_shapes].rank = rank;
        memcpy(g_shapes[g_n_shapes].dims, shape, (size_t)rank * sizeof *shape);
        g_shapes[g_n_shapes].args = args; /* the cache's reference */
        ++g_n_shapes;
        *owned = 0;
        return args;
    }
    *owned = 1;
    return args;
}

/* A new float64 array: (n, *dims) for a batch, dims for one state (nd = 0: a (n,) batch). */
static PyObject *new_array(int batch, Py_ssize_t n, int nd, const Py_ssize_t *dims,
                           double **data)
{
    Py_ssize_t shape[4];
    int rank = 0;
    if (batch) {
        shape[rank++] = n;
    }
    for (int d = 0; d < nd; ++d) {
        shape[rank++] = dims[d];
    }
    int owned;
    PyObject *args = shape_args(rank, shape, !batch, &owned);
    if (args == NULL) {
        return NULL;
    }
    PyObject *arr = PyObject_Call(g_empty, args, NULL);
    if (owned) {
        Py_DECREF(args);
    }
    if (arr == NULL) {
        return NULL;
    }
    *data = array_data(arr);
    if (*data == NULL) {
        Py_DECREF(arr);
        return NULL;
    }
    return arr;
}

/* ------------------------------------------------------------------------------------------ */
/* Arguments: (3,) or (n, 3)                                                                  */
/* ------------------------------------------------------------------------------------------ */

typedef struct {
    const double *data;  /* row 0 */
    Py_ssize_t rows;
    Py_ssize_t step;     /* doubles between the rows the loop reads: NJ, or 0 (broadcast) */
    int batch;           /* given as (n, 3) */
    PyObject *keep;      /* owned: the array as_rows converted, or NULL */
    Py_buffer view;      /* held while data points into it (has_view) */
    int has_view;
    double small[NJ];    /* a list or tuple of three numbers */
} vec_arg;

static void arg_release(vec_arg *a)
{
    if (a->has_view) {
        PyBuffer_Release(&a->view);
        a->has_view = 0;
    }
    Py_CLEAR(a->keep);
}

static void args_release(vec_arg *a, int n)
{
    for (int k = 0; k < n; ++k) {
        arg_release(&a[k]);
    }
}

static int set_shape(vec_arg *a, int ndim, const Py_ssize_t *shape)
{
    if (ndim == 1 && shape[0] == NJ) {
        a->rows = 1;
        a->batch = 0;
        return 1;
    }
    if (ndim == 2 && shape[1] == NJ) {
        a->rows = shape[0];
        a->batch = 1;
        return 1;
    }
    return 0;
}

static int is_aligned(const void *p)
{
    return ((uintptr_t)p % _Alignof(double)) == 0;
}

/* A list or tuple of exactly three floats or ints (numpy would make the same doubles). */
static int from_sequence(PyObject *obj, vec_arg *a)
{
    PyObject *(*item)(PyObject *, Py_ssize_t);
    if (PyList_CheckExact(obj) && PyList_Size(obj) == NJ) {
        item = PyList_GetItem;
    } else if (PyTuple_CheckExact(obj) && PyTuple_Size(obj) == NJ) {
        item = PyTuple_GetItem;
    } else {
        return 0;
    }
    for (Py_ssize_t k = 0; k < NJ; ++k) {
        PyObject *it = item(obj, k); /* borrowed */
        if (PyFloat_CheckExact(it)) {
            a->small[k] = PyFloat_AsDouble(it);
        } else if (PyLong_CheckExact(it)) {
            const double v = PyLong_AsDouble(it);
            if (v == -1.0 && PyErr_Occurred()) {
                PyErr_Clear(); /* too large: as_rows decides */
                return 0;
            }
            a->small[k] = v;
        } else {
            return 0;
        }
    }
    a->data = a->small;
    a->rows = 1;
    a->batch = 0;
    return 1;
}

static int native_double_format(const char *f)
{
    if (f == NULL) {
        return 0; /* "B" */
    }
    if (f[0] == '@' || f[0] == '=' ||
#if PY_LITTLE_ENDIAN
        f[0] == '<'
#else
        f[0] == '>' || f[0] == '!'
#endif
    ) {
        ++f;
    }
    return f[0] == 'd' && f[1] == '\0';
}

/* Any other exporter of C-contiguous native doubles: read in place while the view is held. */
static int from_buffer(PyObject *obj, vec_arg *a)
{
    if (!PyObject_CheckBuffer(obj)) {
        return 0;
    }
    if (PyObject_GetBuffer(obj, &a->view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) != 0) {
        PyErr_Clear(); /* not contiguous, ...: as_rows converts it */
        return 0;
    }
    a->has_view = 1;
    const Py_buffer *v = &a->view;
    if (v->itemsize == (Py_ssize_t)sizeof(double) && native_double_format(v->format) &&
        is_aligned(v->buf) && v->shape != NULL && set_shape(a, v->ndim, v->shape)) {
        a->data = (const double *)v->buf;
        return 1;
    }
    PyBuffer_Release(&a->view);
    a->has_view = 0;
    return 0;
}

/* Everything else: _arrays.as_rows converts it (a float64 (n, 3) array, C-contiguous and aligned)
 * or raises. */
static int from_as_rows(PyObject *obj, const char *name, vec_arg *a)
{
    PyObject *pyname = PyUnicode_FromString(name);
    if (pyname == NULL) {
        return -1;
    }
    PyObject *res = PyObject_CallFunctionObjArgs(g_as_rows, obj, pyname, NULL);
    Py_DECREF(pyname);
    if (res == NULL) {
        return -1;
    }
    if (!PyTuple_Check(res) || PyTuple_Size(res) != 2) {
        Py_DECREF(res);
        PyErr_SetString(PyExc_SystemError, "_arrays.as_rows returned no (array, batch) pair");
        return -1;
    }
    const int batch = PyObject_IsTrue(PyTuple_GetItem(res, 1));
    a->keep = Py_NewRef(PyTuple_GetItem(res, 0));
    Py_DECREF(res);
    if (batch < 0) {
        return -1;
    }
    if (PyObject_GetBuffer(a->keep, &a->view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) != 0) {
        return -1;
    }
    a->has_view = 1;
    const Py_buffer *v = &a->view;
    if (v->itemsize != (Py_ssize_t)sizeof(double) || !native_double_format(v->format) ||
        v->ndim != 2 || v->shape[1] != NJ) {
        PyErr_SetString(PyExc_SystemError, "_arrays.as_rows returned no float64 (n, 3) array");
        return -1;
    }
    if (!is_aligned(v->buf)) {
        PyErr_SetString(PyExc_SystemError, "_arrays.as_rows returned a misaligned array");
        return -1;
    }
    a->rows = v->shape[0];
    a->batch = batch;
    a->data = (const double *)v->buf;
    return 0;
}

static int parse_arg(PyObject *obj, const char *name, vec_arg *a)
{
    memset(a, 0, sizeof *a);
    if (from_buffer(obj, a) || from_sequence(obj, a)) {
        a->step = a->rows == 1 ? 0 : NJ;
        return 0;
    }
    if (from_as_rows(obj, name, a) != 0) {
        arg_release(a);
        return -1;
    }
    a->step = a->rows == 1 ? 0 : NJ;
    return 0;
}

/* Parse args[0..k) in order (the first bad one raises); on failure nothing is held. */
static int parse_args(PyObject *const *args, int k, const char *const *names, vec_arg *a)
{
    for (int i = 0; i < k; ++i) {
        if (parse_arg(args[i], names[i], &a[i]) != 0) {
            args_release(a, i);
            return -1;
        }
    }
    return 0;
}

/* The common row count of a batch: 1-row arguments are repeated. */
static int broadcast(vec_arg *a, int k, const char *const *names, Py_ssize_t *n, int *batch)
{
    *batch = 0;
    *n = 1;
    for (int i = 0; i < k; ++i) {
        *batch |= a[i].batch;
    }
    if (!*batch) {
        return 0;
    }
    Py_ssize_t most = 0;
    for (int i = 0; i < k; ++i) {
        most = a[i].rows > most ? a[i].rows : most;
    }
    for (int i = 0; i < k; ++i) {
        if (a[i].rows != 1 && a[i].rows != most) {
            PyErr_Format(g_bad_input, "%s has %zd rows, expected %zd", names[i], a[i].rows, most);
            return -1;
        }
    }
    *n = most;
    return 0;
}

static int check_nargs(const char *method, Py_ssize_t nargs, int want)
{
    if (nargs != want) {
        PyErr_Format(PyExc_TypeError, "%s() takes %d arguments (%zd given)", method, want, nargs);
        return -1;
    }
    return 0;
}

/* The attribute `name` of the module `module` (imported), or NULL with an exception. */
static PyObject *attr_of(const char *module, const char *name)
{
    PyObject *mod = PyImport_ImportModule(module);
    if (mod == NULL) {
        return NULL;
    }
    PyObject *value = PyObject_GetAttrString(mod, name);
    Py_DECREF(mod);
    return value;
}

/* The exception being raised, taken out of the error indicator (normalized), or NULL. */
static PyObject *raised_exception(void)
{
#if defined(Py_LIMITED_API) ? Py_LIMITED_API >= 0x030C0000 : PY_VERSION_HEX >= 0x030C0000
    return PyErr_GetRaisedException();
#else
    PyObject *type, *value, *tb;
    PyErr_Fetch(&type, &value, &tb);
    PyErr_NormalizeException(&type, &value, &tb);
    if (value != NULL && tb != NULL) {
        PyException_SetTraceback(value, tb);
    }
    Py_XDECREF(type);
    Py_XDECREF(tb);
    return value;
#endif
}

/* ------------------------------------------------------------------------------------------ */
/* Errors                                                                                     */
/* ------------------------------------------------------------------------------------------ */

/* str(row.tolist()) of one row: "[0.1, 0.2, nan]" */
static PyObject *row_repr(const double *row)
{
    PyObject *list = PyList_New(NJ);
    if (list == NULL) {
        return NULL;
    }
    for (Py_ssize_t k = 0; k < NJ; ++k) {
        PyObject *v = PyFloat_FromDouble(row[k]);
        if (v == NULL) {
            Py_DECREF(list);
            return NULL;
        }
        PyList_SetItem(list, k, v); /* steals v; cannot fail here */
    }
    PyObject *text = PyObject_Repr(list);
    Py_DECREF(list);
    return text;
}

/* "<names> = <row 0>, <row 1>, ..." (joined: the rows of a call) or, with names == NULL,
 * "<name 0> = <row 0>, <name 1> = <row 1>, ..." (energy's rows). */
static PyObject *rows_text(const char *joined, const char *const *names, int k,
                           const double *const *rows)
{
    PyObject *parts = PyList_New(0);
    if (parts == NULL) {
        return NULL;
    }
    for (int i = 0; i < k; ++i) {
        PyObject *r = row_repr(rows[i]);
        PyObject *part = NULL;
        if (r != NULL) {
            part = joined != NULL ? Py_NewRef(r) : PyUnicode_FromFormat("%s = %U", names[i], r);
            Py_DECREF(r);
        }
        if (part == NULL || PyList_Append(parts, part) != 0) {
            Py_XDECREF(part);
            Py_DECREF(parts);
            return NULL;
        }
        Py_DECREF(part);
    }
    PyObject *sep = PyUnicode_FromString(", ");
    PyObject *body = sep != NULL ? PyUnicode_Join(sep, parts) : NULL;
    Py_XDECREF(sep);
    Py_DECREF(parts);
    if (body == NULL || joined == NULL) {
        return body;
    }
    PyObject *text = PyUnicode_FromFormat("%s = %U", joined, body);
    Py_DECREF(body);
    return text;
}

/* Raise the package's exception for a non-OK status of C function fn, as _status.raise_for:
 * class ERRORS.get(status, RrrError), message "<fn> failed with <name> (<meaning>)[: context]". */
static void raise_status(const char *fn, int status, PyObject *context)
{
    PyObject *key = PyLong_FromLong(status);
    if (key == NULL) {
        return;
    }
    PyObject *cls = PyDict_GetItemWithError(g_status_errors, key); /* borrowed */
    PyObject *meaning = cls != NULL || !PyErr_Occurred()
                            ? PyDict_GetItemWithError(g_status_meaning, key) /* borrowed */
                            : NULL;
    PyObject *sname = NULL;
    if (!PyErr_Occurred()) {
        sname = status >= 0 && status < PyTuple_Size(g_status_names)
                    ? Py_NewRef(PyTuple_GetItem(g_status_names, status))
                    : PyObject_Str(key);
    }
    Py_DECREF(key);
    if (sname == NULL) {
        return;
    }
    PyObject *text = meaning != NULL ? Py_NewRef(meaning) : PyUnicode_FromString("?");
    PyObject *msg = NULL;
    if (text != NULL) {
        msg = context != NULL && PyUnicode_GetLength(context) > 0
                  ? PyUnicode_FromFormat("%s failed with %U (%U): %U", fn, sname, text, context)
                  : PyUnicode_FromFormat("%s failed with %U (%U)", fn, sname, text);
        Py_DECREF(text);
    }
    if (msg != NULL) {
        PyObject *exc = PyObject_CallFunction(cls != NULL ? cls : g_rrr_error, "OsO", msg, fn,
                                              sname);
        if (exc != NULL) {
            PyErr_SetObject((PyObject *)Py_TYPE(exc), exc);
            Py_DECREF(exc);
        }
        Py_DECREF(msg);
    }
    Py_DECREF(sname);
}

/* The status error of row i: "sample i: <rows_text>". */
static void raise_row(const char *fn, int status, Py_ssize_t i, const char *joined,
                      const char *const *names, int k, const double *const *rows)
{
    PyObject *body = rows_text(joined, names, k, rows);
    if (body == NULL) {
        return;
    }
    PyObject *context = PyUnicode_FromFormat("sample %zd: %U", i, body);
    Py_DECREF(body);
    if (context != NULL) {
        raise_status(fn, status, context);
        Py_DECREF(context);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Row functions: one librrr call on one row, a uniform signature for map_rows                */
/* ------------------------------------------------------------------------------------------ */

typedef rrr_status (*row_fn)(const rrr_model *m, const void *ctx, const double *const *in,
                             double *const *out);

#define M33(p) ((double(*)[NJ])(void *)(p))

static rrr_status row_fk(const rrr_model *m, const void *ctx, const double *const *in,
                         double *const *out)
{
    (void)ctx;
    return rrr_fk(m, in[0], out[0], M33(out[1]));
}

static rrr_status row_fk_frames(const rrr_model *m, const void *ctx, const double *const *in,
                                double *const *out)
{
    (void)ctx;
    return rrr_fk_frames(m, in[0], (double(*)[4][4])(void *)out[0]);
}

static rrr_status row_jacobian(const rrr_model *m, const void *ctx, const double *const *in,
                               double *const *out)
{
    (void)ctx;
    return rrr_jacobian(m, in[0], M33(out[0]));
}

static rrr_status row_tip_motion(const rrr_model *m, const void *ctx, const double *const *in,
                                 double *const *out)
{
    (void)ctx;
    return rrr_tip_motion(m, in[0], in[1], in[2], out[0], out[1]);
}

static rrr_status row_joint_motion(const rrr_model *m, const void *ctx, const double *const *in,
                                   double *const *out)
{
    (void)ctx;
    return rrr_joint_motion(m, in[0], in[1], in[2], out[0], out[1]);
}

typedef struct {
    rrr_shoulder shoulder;
    rrr_elbow elbow;
} posture;

static rrr_status row_ik_branch(const rrr_model *m, const void *ctx, const double *const *in,
                                double *const *out)
{
    const posture *p = ctx;
    return rrr_ik_branch(m, in[0], p->shoulder, p->elbow, out[0]);
}

static rrr_status row_workspace_margin(const rrr_model *m, const void *ctx,
                                       const double *const *in, double *const *out)
{
    (void)ctx;
    return rrr_workspace_margin(m, in[0], out[0], NULL);
}

static rrr_status row_regressor(const rrr_model *m, const void *ctx, const double *const *in,
                                double *const *out)
{
    (void)ctx;
    return rrr_regressor(m, in[0], in[1], in[2], (double(*)[RRR_NP])(void *)out[0]);
}

static rrr_status row_inverse_dynamics(const rrr_model *m, const void *ctx,
                                       const double *const *in, double *const *out)
{
    (void)ctx;
    return rrr_inverse_dynamics(m, in[0], in[1], in[2], out[0]);
}

static rrr_status row_mass_matrix(const rrr_model *m, const void *ctx, const double *const *in,
                                  double *const *out)
{
    (void)ctx;
    return rrr_mass_matrix(m, in[0], M33(out[0]));
}

static rrr_status row_coriolis(const rrr_model *m, const void *ctx, const double *const *in,
                               double *const *out)
{
    (void)ctx;
    return rrr_coriolis(m, in[0], in[1], out[0]);
}

static rrr_status row_gravity(const rrr_model *m, const void *ctx, const double *const *in,
                              double *const *out)
{
    (void)ctx;
    return rrr_gravity(m, in[0], out[0]);
}

static rrr_status row_forward_dynamics(const rrr_model *m, const void *ctx,
                                       const double *const *in, double *const *out)
{
    (void)ctx;
    return rrr_forward_dynamics(m, in[0], in[1], in[2], out[0]);
}

static rrr_status row_energy(const rrr_model *m, const void *ctx, const double *const *in,
                             double *const *out)
{
    (void)ctx;
    return rrr_energy(m, in[0], in[1], out[0], out[1]);
}

static rrr_status row_friction(const rrr_model *m, const void *ctx, const double *const *in,
                               double *const *out)
{
    (void)ctx;
    return rrr_friction(m, in[0], out[0]);
}

static rrr_status row_voltage_from_torque(const rrr_model *m, const void *ctx,
                                          const double *const *in, double *const *out)
{
    (void)ctx;
    return rrr_voltage_from_torque(m, in[0], in[1], out[0]);
}

static rrr_status row_torque_from_voltage(const rrr_model *m, const void *ctx,
                                          const double *const *in, double *const *out)
{
    (void)ctx;
    return rrr_torque_from_voltage(m, in[0], in[1], out[0]);
}

static rrr_status row_ctc(const rrr_model *m, const void *ctx, const double *const *in,
                          double *const *out)
{
    rrr_ctc_output o;
    const rrr_status st = rrr_ctc(m, ctx, in[0], in[1], in[2], in[3], in[4], &o);
    if (st == RRR_OK) {
        memcpy(out[0], o.u, sizeof o.u);
        memcpy(out[1], o.u_n, sizeof o.u_n);
        memcpy(out[2], o.u_c, sizeof o.u_c);
    }
    return st;
}

/* plant_jacobian(q, qd, u) -> (qdd, J): J = d qdd / d(q, qd, u), 3 x 9 */
static rrr_status row_plant_jacobian(const rrr_model *m, const void *ctx,
                                     const double *const *in, double *const *out)
{
    (void)ctx;
    rrr_plant_state x;
    memset(&x, 0, sizeof x);
    memcpy(x.q, in[0], sizeof x.q);
    memcpy(x.qd, in[1], sizeof x.qd);
    rrr_plant_derivatives d;
    const rrr_status st = rrr_plant_jacobian(m, &x, in[2], &d);
    if (st == RRR_OK) {
        memcpy(out[0], d.qdd, sizeof d.qdd);
        for (int i = 0; i < NJ; ++i) {
            memcpy(out[1] + 9 * i, d.dqdd_dq[i], sizeof d.dqdd_dq[i]);
            memcpy(out[1] + 9 * i + 3, d.dqdd_dqd[i], sizeof d.dqdd_dqd[i]);
            memcpy(out[1] + 9 * i + 6, d.dqdd_du[i], sizeof d.dqdd_du[i]);
        }
    }
    return st;
}

/* ctc_jacobian(gains, q_ref, qd_ref, qdd_ref, q, qd) -> (u, du, du_n): du = d u / d(q_ref,
 * qd_ref, qdd_ref, q, qd), 3 x 15 (column 3 k + j: joint j of input k), du_n the same of u_n */
static rrr_status row_ctc_jacobian(const rrr_model *m, const void *ctx,
                                   const double *const *in, double *const *out)
{
    rrr_ctc_derivatives d;
    const rrr_status st = rrr_ctc_jacobian(m, ctx, in[0], in[1], in[2], in[3], in[4], &d);
    if (st == RRR_OK) {
        memcpy(out[0], d.out.u, sizeof d.out.u);
        for (int i = 0; i < NJ; ++i) {
            for (int k = 0; k < RRR_CTC_INPUT_COUNT; ++k) {
                memcpy(out[1] + 15 * i + 3 * k, d.du[k][i], sizeof d.du[k][i]);
                memcpy(out[2] + 15 * i + 3 * k, d.du_n[k][i], sizeof d.du_n[k][i]);
            }
        }
    }
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* map_rows: parse, broadcast, allocate, loop (without the GIL for large batches), report      */
/* ------------------------------------------------------------------------------------------ */

typedef struct {
    const char *method;           /* Kernels method, for argument count errors */
    const char *cname;            /* the librrr function named in errors */
    row_fn fn;
    int n_in;
    const char *in_names[MAX_IN];
    const char *joined;           /* "q, qd, qdd" in a row's message; NULL: "q = ..., qd = ..." */
    int n_out;
    int out_nd[MAX_OUT];          /* rank of one row's output: 0 (a number), 1, 2 or 3 */
    Py_ssize_t out_dims[MAX_OUT][3];
} map_spec;

static Py_ssize_t out_size(const map_spec *s, int j)
{
    Py_ssize_t size = 1;
    for (int d = 0; d < s->out_nd[j]; ++d) {
        size *= s->out_dims[j][d];
    }
    return size;
}

/* Run fn over rows [0, n); the failing row, or -1. Touches no Python object. */
static Py_ssize_t loop_rows(const rrr_model *m, const map_spec *s, const void *ctx,
                            const vec_arg *a, double *const *outs, const Py_ssize_t *sizes,
                            Py_ssize_t n, rrr_status *status)
{
    const double *in[MAX_IN];
    double *out[MAX_OUT];
    for (Py_ssize_t i = 0; i < n; ++i) {
        for (int k = 0; k < s->n_in; ++k) {
            in[k] = a[k].data + i * a[k].step;
        }
        for (int j = 0; j < s->n_out; ++j) {
            out[j] = outs[j] + i * sizes[j];
        }
        const rrr_status st = s->fn(m, ctx, in, out);
        if (st != RRR_OK) {
            *status = st;
            return i;
        }
    }
    return -1;
}

static Py_ssize_t run_rows(const rrr_model *m, const map_spec *s, const void *ctx,
                           const vec_arg *a, double *const *outs, const Py_ssize_t *sizes,
                           Py_ssize_t n, rrr_status *status)
{
    Py_ssize_t bad;
    if (n >= RRR_EXT_NOGIL_ROWS) {
        Py_BEGIN_ALLOW_THREADS
        bad = loop_rows(m, s, ctx, a, outs, sizes, n, status);
        Py_END_ALLOW_THREADS
    } else {
        bad = loop_rows(m, s, ctx, a, outs, sizes, n, status);
    }
    return bad;
}

static void raise_failed_row(const map_spec *s, const vec_arg *a, Py_ssize_t i, rrr_status st)
{
    const double *rows[MAX_IN];
    for (int k = 0; k < s->n_in; ++k) {
        rows[k] = a[k].data + i * a[k].step;
    }
    raise_row(s->cname, (int)st, i, s->joined, s->in_names, s->n_in, rows);
}

/* The outputs of a map, for parsed and broadcast arguments: one array (or number) or a tuple. */
/* The result of n_out output objects: the one object, or a tuple of them; the objects move
 * into the result (their slots set to NULL) when it is made. */
static PyObject *pack_outputs(PyObject **arrays, int n_out)
{
    if (n_out == 1) {
        PyObject *one = arrays[0];
        arrays[0] = NULL;
        return one;
    }
    PyObject *tuple = PyTuple_New(n_out);
    if (tuple != NULL) {
        for (int j = 0; j < n_out; ++j) {
            PyTuple_SetItem(tuple, j, arrays[j]); /* steals it */
            arrays[j] = NULL;
        }
    }
    return tuple;
}

/* Output arrays given by the caller (out=): held as buffer views while the call writes them. */
typedef struct {
    int given;
    PyObject *obj[MAX_OUT];
    Py_buffer view[MAX_OUT];
    int held;
} out_args;

static void out_release(out_args *o)
{
    for (int j = 0; j < o->held; ++j) {
        PyBuffer_Release(&o->view[j]);
    }
    o->held = 0;
}

/* The result objects of a call: the caller's out= arrays (o given), else new arrays, of which
 * one state's number outputs (rank 0) stay NULL with outs[j] = &scalars[j]. -1 raised. */
static HOT_INLINE int result_arrays(const map_spec *s, const out_args *o, Py_ssize_t n,
                                    int batch, PyObject **arrays, double **outs,
                                    double *scalars)
{
    for (int j = 0; j < s->n_out; ++j) {
        if (o != NULL && o->given) {
            arrays[j] = Py_NewRef(o->obj[j]);
            outs[j] = (double *)o->view[j].buf;
        } else if (!batch && s->out_nd[j] == 0) {
            outs[j] = &scalars[j];
        } else {
            arrays[j] = new_array(batch, n, s->out_nd[j], s->out_dims[j], &outs[j]);
            if (arrays[j] == NULL) {
                return -1;
            }
        }
    }
    return 0;
}

static PyObject *map_parsed(const rrr_model *m, const map_spec *s, const void *ctx,
                            const vec_arg *a, Py_ssize_t n, int batch, const out_args *o)
{
    PyObject *arrays[MAX_OUT] = {NULL};
    double *outs[MAX_OUT];
    Py_ssize_t sizes[MAX_OUT];
    double scalars[MAX_OUT]; /* one state's number outputs */
    PyObject *result = NULL;
    for (int j = 0; j < s->n_out; ++j) {
        sizes[j] = out_size(s, j);
    }
    if (result_arrays(s, o, n, batch, arrays, outs, scalars) != 0) {
        goto done;
    }
    rrr_status st = RRR_OK;
    const Py_ssize_t bad = run_rows(m, s, ctx, a, outs, sizes, n, &st);
    if (bad >= 0) {
        raise_failed_row(s, a, bad, st);
        goto done;
    }
    for (int j = 0; j < s->n_out; ++j) {
        if (arrays[j] == NULL) {
            arrays[j] = PyFloat_FromDouble(scalars[j]);
            if (arrays[j] == NULL) {
                goto done;
            }
        }
    }
    result = pack_outputs(arrays, s->n_out);
done:
    for (int j = 0; j < s->n_out; ++j) {
        Py_XDECREF(arrays[j]);
    }
    return result;
}

static PyObject *map_rows(const rrr_model *m, const map_spec *s, const void *ctx,
                          PyObject *const *args)
{
    vec_arg a[MAX_IN];
    if (parse_args(args, s->n_in, s->in_names, a) != 0) {
        return NULL;
    }
    Py_ssize_t n;
    int batch;
    PyObject *result = NULL;
    if (broadcast(a, s->n_in, s->in_names, &n, &batch) == 0) {
        result = map_parsed(m, s, ctx, a, n, batch, NULL);
    }
    args_release(a, s->n_in);
    return result;
}

/* ------------------------------------------------------------------------------------------ */
/* Kernels                                                                                    */
/* ------------------------------------------------------------------------------------------ */

typedef struct {
    PyObject_HEAD
    PyObject *owner;      /* the ctypes RawModel */
    Py_buffer view;       /* its memory, exported while the Kernels lives */
    const rrr_model *m;
} KernelsObject;

static PyObject *Kernels_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    PyObject *raw;
    static char *kwlist[] = {"raw", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O:Kernels", kwlist, &raw)) {
        return NULL;
    }
    Py_buffer view;
    if (PyObject_GetBuffer(raw, &view, PyBUF_SIMPLE) != 0) {
        return NULL;
    }
    if (view.len != (Py_ssize_t)sizeof(rrr_model) || !is_aligned(view.buf)) {
        PyErr_Format(PyExc_TypeError,
                     "Kernels needs an aligned rrr_model of %zu bytes (a RawModel), got %zd bytes",
                     sizeof(rrr_model), view.len);
        PyBuffer_Release(&view);
        return NULL;
    }
    allocfunc alloc;
    void *slot = PyType_GetSlot(type, Py_tp_alloc);
    memcpy(&alloc, &slot, sizeof alloc); /* a function's address kept in a void * */
    KernelsObject *self = (KernelsObject *)alloc(type, 0);
    if (self == NULL) {
        PyBuffer_Release(&view);
        return NULL;
    }
    self->owner = Py_NewRef(raw);
    self->view = view;
    self->m = (const rrr_model *)view.buf;
    return (PyObject *)self;
}

static void Kernels_dealloc(PyObject *op)
{
    KernelsObject *self = (KernelsObject *)op;
    if (self->owner != NULL) {
        PyBuffer_Release(&self->view);
        Py_CLEAR(self->owner);
    }
    PyTypeObject *type = Py_TYPE(op);
    freefunc free_fn;
    void *slot = PyType_GetSlot(type, Py_tp_free);
    memcpy(&free_fn, &slot, sizeof free_fn); /* a function's address kept in a void * */
    free_fn(op);
    Py_DECREF(type); /* a heap type: its instances hold a reference */
}

#define MODEL(op) (((KernelsObject *)(op))->m)

static const map_spec S_FK = {"fk", "rrr_fk", row_fk, 1, {"q"}, "q",
                              2, {1, 2}, {{NJ, 0}, {NJ, NJ}}};
static const map_spec S_FK_FRAMES = {"fk_frames", "rrr_fk_frames", row_fk_frames, 1, {"q"}, "q",
                                     1, {3}, {{RRR_NFRAMES, 4, 4}}};
static const map_spec S_JACOBIAN = {"jacobian", "rrr_jacobian", row_jacobian, 1, {"q"}, "q",
                                    1, {2}, {{NJ, NJ}}};
static const map_spec S_TIP_MOTION = {"tip_motion", "rrr_tip_motion", row_tip_motion,
                                      3, {"q", "qd", "qdd"}, "q, qd, qdd",
                                      2, {1, 1}, {{NJ, 0}, {NJ, 0}}};
static const map_spec S_JOINT_MOTION = {"joint_motion", "rrr_joint_motion", row_joint_motion,
                                        3, {"q", "xd", "xdd"}, "q, xd, xdd",
                                        2, {1, 1}, {{NJ, 0}, {NJ, 0}}};
static const map_spec S_IK_BRANCH = {"ik_branch", "rrr_ik_branch", row_ik_branch, 1, {"x"}, "x",
                                     1, {1}, {{NJ, 0}}};
static const map_spec S_WORKSPACE_MARGIN = {"workspace_margin", "rrr_workspace_margin",
                                            row_workspace_margin, 1, {"x"}, "x",
                                            1, {0}, {{0, 0}}};
static const map_spec S_REGRESSOR = {"regressor", "rrr_regressor", row_regressor,
                                     3, {"q", "qd", "qdd"}, "q, qd, qdd",
                                     1, {2}, {{NJ, RRR_NP}}};
static const map_spec S_INVERSE_DYNAMICS = {"inverse_dynamics", "rrr_inverse_dynamics",
                                            row_inverse_dynamics, 3, {"q", "qd", "qdd"},
                                            "q, qd, qdd", 1, {1}, {{NJ, 0}}};
static const map_spec S_MASS_MATRIX = {"mass_matrix", "rrr_mass_matrix", row_mass_matrix,
                                       1, {"q"}, "q", 1, {2}, {{NJ, NJ}}};
static const map_spec S_CORIOLIS = {"coriolis", "rrr_coriolis", row_coriolis,
                                    2, {"q", "qd"}, "q, qd", 1, {1}, {{NJ, 0}}};
static const map_spec S_GRAVITY = {"gravity", "rrr_gravity", row_gravity, 1, {"q"}, "q",
                                   1, {1}, {{NJ, 0}}};
static const map_spec S_FORWARD_DYNAMICS = {"forward_dynamics", "rrr_forward_dynamics",
                                            row_forward_dynamics, 3, {"q", "qd", "tau"},
                                            "q, qd, tau", 1, {1}, {{NJ, 0}}};
static const map_spec S_ENERGY = {"energy", "rrr_energy", row_energy, 2, {"q", "qd"}, NULL,
                                  2, {0, 0}, {{0, 0}, {0, 0}}};
static const map_spec S_FRICTION = {"friction", "rrr_friction", row_friction, 1, {"qd"}, "qd",
                                    1, {1}, {{NJ, 0}}};
static const map_spec S_VOLTAGE_FROM_TORQUE = {"voltage_from_torque", "rrr_voltage_from_torque",
                                               row_voltage_from_torque, 2, {"qd", "tau"},
                                               "qd, tau", 1, {1}, {{NJ, 0}}};
static const map_spec S_TORQUE_FROM_VOLTAGE = {"torque_from_voltage", "rrr_torque_from_voltage",
                                               row_torque_from_voltage, 2, {"qd", "u"}, "qd, u",
                                               1, {1}, {{NJ, 0}}};
static const map_spec S_CTC = {"ctc", "rrr_ctc", row_ctc, 5,
                               {"q_ref", "qd_ref", "qdd_ref", "q", "qd"},
                               "q_ref, qd_ref, qdd_ref, q, qd",
                               3, {1, 1, 1}, {{NJ, 0}, {NJ, 0}, {NJ, 0}}};

static const map_spec S_PLANT_JACOBIAN = {"plant_jacobian", "rrr_plant_jacobian",
                                          row_plant_jacobian, 3, {"q", "qd", "u"}, "q, qd, u",
                                          2, {1, 2}, {{NJ, 0}, {NJ, 9}}};
static const map_spec S_CTC_JACOBIAN = {"ctc_jacobian", "rrr_ctc_jacobian", row_ctc_jacobian, 5,
                                        {"q_ref", "qd_ref", "qdd_ref", "q", "qd"},
                                        "q_ref, qd_ref, qdd_ref, q, qd",
                                        3, {1, 2, 2}, {{NJ, 0}, {NJ, 15}, {NJ, 15}}};

static PyObject *map_method(PyObject *self, const map_spec *s, PyObject *const *args,
                            Py_ssize_t nargs)
{
    if (check_nargs(s->method, nargs, s->n_in) != 0) {
        return NULL;
    }
    return map_rows(MODEL(self), s, NULL, args);
}

#define MAP_METHOD(name, spec)                                                           \
    static PyObject *K_##name(PyObject *self, PyObject *const *args, Py_ssize_t nargs) \
    {                                                                                    \
        return map_method(self, &(spec), args, nargs);                                   \
    }

MAP_METHOD(fk_frames, S_FK_FRAMES)
MAP_METHOD(jacobian, S_JACOBIAN)
MAP_METHOD(tip_motion, S_TIP_MOTION)
MAP_METHOD(joint_motion, S_JOINT_MOTION)
MAP_METHOD(workspace_margin, S_WORKSPACE_MARGIN)
/* ------------------------------------------------------------------------------------------ */
/* The path and out arguments of the batch methods                                            */
/* ------------------------------------------------------------------------------------------ */

/* The rrr_simd of a path argument: a simd= name (Model passes its argument as it is: the
 * default "auto" is found by identity, with no look-up) or an rrr_simd value (int). A name that
 * is not a path here raises batch.refuse's BadInputError; an int that is not, ValueError. */
static int path_of(PyObject *obj, const char *method, rrr_simd *path)
{
    for (int v = RRR_SIMD_AUTO; v <= RRR_SIMD_AVX512; ++v) {
        if (obj == g_simd_names[v]) {
            *path = (rrr_simd)v;
            return v > RRR_SIMD_SCALAR && !rrr_simd_available(*path) ? -2 : 0;
        }
    }
    if (PyUnicode_Check(obj)) {
        for (int v = RRR_SIMD_AUTO; v <= RRR_SIMD_AVX512; ++v) {
            if (PyUnicode_Compare(obj, g_simd_names[v]) == 0) {
                *path = (rrr_simd)v;
                return v > RRR_SIMD_SCALAR && !rrr_simd_available(*path) ? -2 : 0;
            }
        }
        return -2;
    }
    if (!PyLong_Check(obj)) {
        return -2;
    }
    const long v = PyLong_AsLong(obj);
    if (v == -1 && PyErr_Occurred()) {
        return -1;
    }
    if (v < RRR_SIMD_AUTO || v > RRR_SIMD_AVX512 ||
        (v > RRR_SIMD_SCALAR && !rrr_simd_available((rrr_simd)v))) {
        PyErr_Format(PyExc_ValueError, "%s: batch path %ld is not available here "
                     "(rrr_simd_available)", method, v);
        return -1;
    }
    *path = (rrr_simd)v;
    return 0;
}

/* path_of, raising batch.refuse's error for what it refuses (-1). */
static int parse_path(PyObject *obj, const char *method, rrr_simd *path)
{
    const int r = path_of(obj, method, path);
    if (r == -2) {
        PyObject *refuse = attr_of("rrr_robot.core.batch", "refuse"); /* imports _ext */
        PyObject *none = refuse != NULL ? PyObject_CallFunctionObjArgs(refuse, obj, NULL) : NULL;
        Py_XDECREF(refuse);
        Py_XDECREF(none); /* refuse raises */
        if (!PyErr_Occurred()) {
            PyErr_SetString(PyExc_SystemError, "batch.refuse returned");
        }
        return -1;
    }
    return r;
}

/* Whether [p, p + np) and [q, q + nq) (bytes) share a byte. */
static int overlaps(const void *p, size_t np, const void *q, size_t nq)
{
    const uintptr_t a = (uintptr_t)p;
    const uintptr_t b = (uintptr_t)q;
    return np > 0 && nq > 0 && a < b + nq && b < a + np;
}

/* Parse out= of a call with n_in parsed inputs and n rows (batch: (n, ...) results): None, one
 * array for one output, a tuple of n_out arrays for more. Each must be a writable, C-contiguous,
 * aligned float64 buffer of exactly the result's shape, sharing no memory with an input or with
 * another output. -1 (BadInputError) otherwise. */
static int parse_out(PyObject *obj, const map_spec *s, const vec_arg *a, Py_ssize_t n, int batch,
                     out_args *o)
{
    o->given = 0;
    o->held = 0;
    if (obj == Py_None) {
        return 0;
    }
    o->given = 1;
    if (s->n_out == 1) {
        o->obj[0] = obj;
    } else if (PyTuple_Check(obj) && PyTuple_Size(obj) == s->n_out) {
        for (int j = 0; j < s->n_out; ++j) {
            o->obj[j] = PyTuple_GetItem(obj, j); /* borrowed */
        }
    } else {
        PyObject *tname = PyType_GetName(Py_TYPE(obj));
        if (tname != NULL) {
            PyErr_Format(g_bad_input, "%s: out must be a tuple of %d arrays, got %U", s->method,
                         s->n_out, tname);
            Py_DECREF(tname);
        }
        return -1;
    }
    for (int j = 0; j < s->n_out; ++j) {
        Py_ssize_t shape[4];
        int rank = 0;
        if (batch) {
            shape[rank++] = n;
        }
        for (int d = 0; d < s->out_nd[j]; ++d) {
            shape[rank++] = s->out_dims[j][d];
        }
        char want[64];
        int len = 0;
        for (int d = 0; d < rank; ++d) {
            len += snprintf(want + len, sizeof want - (size_t)len, d ? ", %zd" : "%zd", shape[d]);
        }
        if (rank == 1) {
            snprintf(want + len, sizeof want - (size_t)len, ",");
        }
        Py_buffer *v = &o->view[j];
        if (PyObject_GetBuffer(o->obj[j], v, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS |
                               PyBUF_FORMAT) != 0) {
            /* why the exporter refused (read-only, not contiguous, no buffer) */
            PyObject *why = raised_exception();
            PyObject *tname = PyType_GetName(Py_TYPE(o->obj[j]));
            if (tname != NULL) {
                PyErr_Format(g_bad_input, "%s: out must be writable, C-contiguous float64 "
                             "arrays of shape (%s); %U: %S", s->method, want, tname, why);
                Py_DECREF(tname);
            }
            Py_XDECREF(why);
            out_release(o);
            return -1;
        }
        o->held = j + 1;
        int ok = v->itemsize == (Py_ssize_t)sizeof(double) && native_double_format(v->format) &&
                 is_aligned(v->buf) && v->ndim == rank && v->shape != NULL;
        for (int d = 0; ok && d < rank; ++d) {
            ok = v->shape[d] == shape[d];
        }
        if (!ok) {
            char got[64] = "";
            int at = 0;
            for (int d = 0; v->shape != NULL && d < v->ndim && at < (int)sizeof got - 24; ++d) {
                at += snprintf(got + at, sizeof got - (size_t)at, d ? ", %zd" : "%zd",
                               v->shape[d]);
            }
            PyErr_Format(g_bad_input, "%s: out must be a float64 array of shape (%s), "
                         "C-contiguous and aligned; got shape (%s%s) of format '%s'", s->method,
                         want, got, v->ndim == 1 ? "," : "", v->format ? v->format : "B");
            out_release(o);
            return -1;
        }
        for (int k = 0; k < s->n_in; ++k) {
            const size_t in_len = (size_t)((a[k].rows - 1) * a[k].step + NJ) * sizeof(double);
            if (overlaps(v->buf, (size_t)v->len, a[k].data, in_len)) {
                PyErr_Format(g_bad_input, "%s: out shares memory with %s: the results would "
                             "overwrite inputs still to be read", s->method, s->in_names[k]);
                out_release(o);
                return -1;
            }
        }
        for (int i = 0; i < j; ++i) {
            if (overlaps(v->buf, (size_t)v->len, o->view[i].buf, (size_t)o->view[i].len)) {
                PyErr_Format(g_bad_input, "%s: the arrays of out share memory", s->method);
                out_release(o);
                return -1;
            }
        }
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Batch methods: name(inputs...[, path[, out]]) -> one state, or a batch through librrr's     */
/* batch kernels (rrr_batch.h) on `path` (path_of; without it, or on the scalar path: the row  */
/* loop, bit for bit the one-state call), into the caller's arrays `out` (parse_out) or new    */
/* ones. Broadcast rows are expanded into a buffer of this call's; a failing row raises as the */
/* row loop does (out then holds the rows before it; the rest is unspecified).                 */
/* ------------------------------------------------------------------------------------------ */

typedef rrr_status (*batch_fn)(const rrr_model *m, const void *ctx, size_t n,
                               const double *const *in, double *const *out, rrr_simd path,
                               size_t *done);

static rrr_status batch_regressor(const rrr_model *m, const void *ctx, size_t n,
                                  const double *const *in, double *const *out, rrr_simd path,
                                  size_t *done)
{
    (void)ctx;
    return rrr_regressor_batch(m, n, in[0], in[1], in[2], out[0], path, done);
}

static rrr_status batch_inverse_dynamics(const rrr_model *m, const void *ctx, size_t n,
                                         const double *const *in, double *const *out, rrr_simd path,
                                         size_t *done)
{
    (void)ctx;
    return rrr_inverse_dynamics_batch(m, n, in[0], in[1], in[2], out[0], path, done);
}

static rrr_status batch_fk(const rrr_model *m, const void *ctx, size_t n,
                           const double *const *in, double *const *out, rrr_simd path,
                           size_t *done)
{
    (void)ctx;
    return rrr_fk_batch(m, n, in[0], out[0], out[1], path, done);
}

static rrr_status batch_forward_dynamics(const rrr_model *m, const void *ctx, size_t n,
                                         const double *const *in, double *const *out, rrr_simd path,
                                         size_t *done)
{
    (void)ctx;
    return rrr_forward_dynamics_batch(m, n, in[0], in[1], in[2], out[0], path, done);
}

static rrr_status batch_ik_branch(const rrr_model *m, const void *ctx, size_t n,
                                  const double *const *in, double *const *out, rrr_simd path,
                                  size_t *done)
{
    const posture *p = ctx;
    return rrr_ik_batch(m, n, in[0], p->shoulder, p->elbow, out[0], NULL, path, done);
}

/* The outputs of a batch call on parsed and broadcast arguments with n > 0 rows. */
static PyObject *batch_parsed(const rrr_model *m, const map_spec *s, batch_fn fn,
                              const void *ctx, const vec_arg *a, Py_ssize_t n, rrr_simd path,
                              const out_args *o)
{
    /* every input as n contiguous rows: broadcast ones copied into one buffer */
    const double *rows[MAX_IN];
    int expand = 0;
    for (int i = 0; i < s->n_in; ++i) {
        expand += a[i].step == 0 && n > 1;
    }
    double *buf = NULL;
    if (expand > 0) {
        buf = PyMem_Malloc((size_t)expand * (size_t)n * NJ * sizeof *buf);
        if (buf == NULL) {
            return PyErr_NoMemory();
        }
    }
    double *next = buf;
    for (int i = 0; i < s->n_in; ++i) {
        if (a[i].step == 0 && n > 1) {
            for (Py_ssize_t k = 0; k < n; ++k) {
                memcpy(&next[k * NJ], a[i].data, NJ * sizeof *next);
            }
            rows[i] = next;
            next += n * NJ;
        } else {
            rows[i] = a[i].data;
        }
    }
    PyObject *arrays[MAX_OUT] = {NULL};
    double *outs[MAX_OUT];
    double scalars[MAX_OUT];
    PyObject *result = NULL;
    if (result_arrays(s, o, n, 1, arrays, outs, scalars) != 0) {
        goto done;
    }
    size_t ok = 0;
    rrr_status st;
    Py_BEGIN_ALLOW_THREADS
    st = fn(m, ctx, (size_t)n, rows, outs, path, &ok);
    Py_END_ALLOW_THREADS
    if (st != RRR_OK) {
        raise_failed_row(s, a, (Py_ssize_t)ok, st);
        goto done;
    }
    result = pack_outputs(arrays, s->n_out);
done:
    for (int j = 0; j < s->n_out; ++j) {
        Py_XDECREF(arrays[j]);
    }
    PyMem_Free(buf);
    return result;
}

/* A batch method's call on the inputs in[0..n_in): path_obj NULL (the row loop) or a path
 * (path_of), out_obj None or the caller's arrays (parse_out). One state, an empty batch and the
 * scalar path run the row loop; a batch on another path fn. */
static HOT_INLINE PyObject *batch_call(PyObject *self, const map_spec *s, batch_fn fn,
                                       const void *ctx, PyObject *const *in,
                                       PyObject *path_obj, PyObject *out_obj)
{
    rrr_simd path = RRR_SIMD_SCALAR;
    if (path_obj != NULL && parse_path(path_obj, s->method, &path) != 0) {
        return NULL;
    }
    vec_arg a[MAX_IN];
    if (parse_args(in, s->n_in, s->in_names, a) != 0) {
        return NULL;
    }
    Py_ssize_t n;
    int batch;
    out_args o;
    PyObject *result = NULL;
    if (broadcast(a, s->n_in, s->in_names, &n, &batch) == 0 &&
        parse_out(out_obj, s, a, n, batch, &o) == 0) {
        if (!batch || path == RRR_SIMD_SCALAR || n == 0) {
            result = map_parsed(MODEL(self), s, ctx, a, n, batch, &o);
        } else {
            result = batch_parsed(MODEL(self), s, fn, ctx, a, n, path, &o);
        }
        out_release(&o);
    }
    args_release(a, s->n_in);
    return result;
}

/* name(inputs...[, path[, out]]) */
static PyObject *batch_method(PyObject *self, const map_spec *s, batch_fn fn,
                              PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs < s->n_in || nargs > s->n_in + 2) {
        PyErr_Format(PyExc_TypeError, "%s() takes %d to %d arguments (%zd given)", s->method,
                     s->n_in, s->n_in + 2, nargs);
        return NULL;
    }
    return batch_call(self, s, fn, NULL, args, nargs > s->n_in ? args[s->n_in] : NULL,
                      nargs > s->n_in + 1 ? args[s->n_in + 1] : Py_None);
}

#define BATCH_METHOD(name, spec)                                                         \
    static PyObject *K_##name(PyObject *self, PyObject *const *args, Py_ssize_t nargs) \
    {                                                                                    \
        return batch_method(self, &(spec), batch_##name, args, nargs);                   \
    }

BATCH_METHOD(regressor, S_REGRESSOR)
BATCH_METHOD(inverse_dynamics, S_INVERSE_DYNAMICS)
BATCH_METHOD(forward_dynamics, S_FORWARD_DYNAMICS)
MAP_METHOD(mass_matrix, S_MASS_MATRIX)
MAP_METHOD(coriolis, S_CORIOLIS)
MAP_METHOD(gravity, S_GRAVITY)
BATCH_METHOD(fk, S_FK)
MAP_METHOD(energy, S_ENERGY)
MAP_METHOD(friction, S_FRICTION)
MAP_METHOD(voltage_from_torque, S_VOLTAGE_FROM_TORQUE)
MAP_METHOD(torque_from_voltage, S_TORQUE_FROM_VOLTAGE)
MAP_METHOD(plant_jacobian, S_PLANT_JACOBIAN)

/* ik_branch(x, shoulder, elbow[, path[, out]]): shoulder 0 front / 1 back, elbow 0 up / 1 down;
 * one target, or rows by the row loop of rrr_ik_branch (without path, or on the scalar path), or
 * by rrr_ik_batch on `path`; the first row that fails raises its error, as in the other batch
 * methods. */
static PyObject *K_ik_branch(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs < 3 || nargs > 5) {
        PyErr_Format(PyExc_TypeError, "ik_branch() takes 3 to 5 arguments (%zd given)", nargs);
        return NULL;
    }
    const long shoulder = PyLong_AsLong(args[1]);
    const long elbow = PyLong_AsLong(args[2]);
    if (PyErr_Occurred()) {
        return NULL;
    }
    if ((shoulder != 0 && shoulder != 1) || (elbow != 0 && elbow != 1)) {
        PyErr_Format(g_bad_input, "posture indices must be 0 or 1, got %ld, %ld", shoulder, elbow);
        return NULL;
    }
    const posture p = {shoulder ? RRR_SHOULDER_BACK : RRR_SHOULDER_FRONT,
                       elbow ? RRR_ELBOW_DOWN : RRR_ELBOW_UP};
    return batch_call(self, &S_IK_BRANCH, batch_ik_branch, &p, args, nargs > 3 ? args[3] : NULL,
                      nargs > 4 ? args[4] : Py_None);
}

/* One target only: parse x and refuse a batch with the method's message. */
static int one_target(PyObject *obj, const char *name, const char *refusal, vec_arg *a)
{
    if (parse_arg(obj, name, a) != 0) {
        return -1;
    }
    if (a->batch) {
        arg_release(a);
        PyErr_SetString(g_bad_input, refusal);
        return -1;
    }
    return 0;
}

static int solve_ik(PyObject *self, PyObject *const *args, Py_ssize_t nargs, const char *method,
                    const char *refusal, rrr_ik_set *sol)
{
    if (check_nargs(method, nargs, 1) != 0) {
        return -1;
    }
    vec_arg x;
    if (one_target(args[0], "x", refusal, &x) != 0) {
        return -1;
    }
    const rrr_status st = rrr_ik(MODEL(self), x.data, sol);
    if (st != RRR_OK) {
        PyObject *r = row_repr(x.data);
        PyObject *context = r != NULL ? PyUnicode_FromFormat("x = %U", r) : NULL;
        Py_XDECREF(r);
        if (context != NULL) {
            raise_status("rrr_ik", (int)st, context);
            Py_DECREF(context);
        }
    }
    arg_release(&x);
    return st == RRR_OK ? 0 : -1;
}

static PyObject *K_ik(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    rrr_ik_set sol;
    if (solve_ik(self, args, nargs, "ik",
                 "ik without a posture takes one target (3,) (every branch); a batch (n, 3) "
                 "needs a posture: ik(x, shoulder, elbow); ik_nearest follows a path",
                 &sol) != 0) {
        return NULL;
    }
    const Py_ssize_t dims[2] = {sol.n, NJ};
    double *data;
    PyObject *out = new_array(0, 0, 2, dims, &data);
    if (out != NULL) {
        memcpy(data, sol.q, (size_t)sol.n * sizeof sol.q[0]);
    }
    return out;
}

static PyObject *K_ik_branches(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    rrr_ik_set sol;
    if (solve_ik(self, args, nargs, "ik_branches",
                 "ik_branches takes one target (3,), as ik does", &sol) != 0) {
        return NULL;
    }
    PyObject *out = PyList_New(sol.n);
    if (out == NULL) {
        return NULL;
    }
    for (int i = 0; i < sol.n; ++i) {
        PyList_SetItem(out, i, Py_NewRef(PyTuple_GetItem(g_branch_names, sol.branch[i] & 3)));
    }
    return out;
}

/* ik_nearest's rows: each solution seeds the next row. The failing row, or -1. */
static Py_ssize_t nearest_rows(const rrr_model *m, const vec_arg *x, const double *seed,
                               double *q, Py_ssize_t n, rrr_status *status)
{
    const double *prev = seed;
    for (Py_ssize_t i = 0; i < n; ++i) {
        const rrr_status st = rrr_ik_nearest(m, x->data + i * x->step, prev, q + i * NJ, NULL);
        if (st != RRR_OK) {
            *status = st;
            return i;
        }
        prev = q + i * NJ;
    }
    return -1;
}

static PyObject *K_ik_nearest(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_nargs("ik_nearest", nargs, 2) != 0) {
        return NULL;
    }
    vec_arg x, prev;
    if (parse_arg(args[0], "x", &x) != 0) {
        return NULL;
    }
    if (parse_arg(args[1], "q_prev", &prev) != 0) {
        arg_release(&x);
        return NULL;
    }
    PyObject *out = NULL;
    if (prev.batch) {
        PyErr_Format(g_bad_input,
                     "q_prev must have shape (3,) (the seed of the first target), got (%zd, %d)",
                     prev.rows, NJ);
        goto done;
    }
    const Py_ssize_t dims[1] = {NJ};
    double *q;
    out = new_array(x.batch, x.rows, 1, dims, &q);
    if (out == NULL) {
        goto done;
    }
    double seed[NJ];
    memcpy(seed, prev.data, sizeof seed);
    rrr_status st = RRR_OK;
    Py_ssize_t bad;
    if (x.rows >= RRR_EXT_NOGIL_ROWS) {
        Py_BEGIN_ALLOW_THREADS
        bad = nearest_rows(MODEL(self), &x, seed, q, x.rows, &st);
        Py_END_ALLOW_THREADS
    } else {
        bad = nearest_rows(MODEL(self), &x, seed, q, x.rows, &st);
    }
    if (bad >= 0) {
        static const char *const name[1] = {"x"};
        const double *row = x.data + bad * x.step;
        raise_row("rrr_ik_nearest", (int)st, bad, "x", name, 1, &row);
        Py_CLEAR(out);
    }
done:
    arg_release(&x);
    arg_release(&prev);
    return out;
}

/* float(value), finite, else BadInputError (model._finite_scalar). */
static int finite_scalar(PyObject *value, const char *name, double *out)
{
    PyObject *f = PyNumber_Float(value);
    if (f == NULL) {
        if (!PyErr_ExceptionMatches(PyExc_TypeError) && !PyErr_ExceptionMatches(PyExc_ValueError)) {
            return -1;
        }
        PyObject *cause = raised_exception();
        PyObject *msg = PyUnicode_FromFormat("%s must be a finite number, got %R", name, value);
        PyObject *exc = msg != NULL ? PyObject_CallFunctionObjArgs(g_bad_input, msg, NULL) : NULL;
        Py_XDECREF(msg);
        if (exc == NULL) {
            Py_XDECREF(cause);
            return -1;
        }
        PyException_SetContext(exc, Py_XNewRef(cause));
        PyException_SetCause(exc, cause); /* raise ... from exc */
        PyErr_SetObject((PyObject *)Py_TYPE(exc), exc);
        Py_DECREF(exc);
        return -1;
    }
    const double v = PyFloat_AsDouble(f);
    if (!isfinite(v)) {
        PyErr_Format(g_bad_input, "%s must be a finite number, got %R", name, f);
        Py_DECREF(f);
        return -1;
    }
    Py_DECREF(f);
    *out = v;
    return 0;
}

/* singularity(q, tol) -> (stretched, folded, shoulder, elbow_margin, shoulder_margin, det_J) */
static PyObject *K_singularity(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_nargs("singularity", nargs, 2) != 0) {
        return NULL;
    }
    vec_arg q;
    if (one_target(args[0], "q",
                   "singularity takes one configuration (3,); classify a path row by row",
                   &q) != 0) {
        return NULL;
    }
    double tol;
    PyObject *out = NULL;
    if (finite_scalar(args[1], "tol", &tol) == 0) {
        rrr_singularity s;
        const rrr_status st = rrr_singularity_classify(MODEL(self), q.data, tol, &s);
        if (st == RRR_OK) {
            out = Py_BuildValue("(NNNddd)", PyBool_FromLong(s.flags & RRR_SING_ELBOW_STRETCHED),
                                PyBool_FromLong(s.flags & RRR_SING_ELBOW_FOLDED),
                                PyBool_FromLong(s.flags & RRR_SING_SHOULDER), s.elbow_margin,
                                s.shoulder_margin, s.det_jacobian);
        } else {
            PyObject *r = row_repr(q.data);
            PyObject *context = r != NULL ? PyUnicode_FromFormat("q = %U", r) : NULL;
            Py_XDECREF(r);
            if (context != NULL) {
                raise_status("rrr_singularity_classify", (int)st, context);
                Py_DECREF(context);
            }
        }
    }
    arg_release(&q);
    return out;
}

/* nominal_voltage(q, qd, qdd): every row's tau = R p first, then u = tau / k_t + u_f(qd), as
 * Model.voltage_from_torque(qd, Model.inverse_dynamics(q, qd, qdd)) (the same refusals). */
static PyObject *K_nominal_voltage(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    const map_spec *s = &S_INVERSE_DYNAMICS;
    if (check_nargs("nominal_voltage", nargs, 3) != 0) {
        return NULL;
    }
    vec_arg a[3];
    if (parse_args(args, 3, s->in_names, a) != 0) {
        return NULL;
    }
    Py_ssize_t n;
    int batch;
    PyObject *out = NULL;
    if (broadcast(a, 3, s->in_names, &n, &batch) == 0) {
        PyObject *tau = map_parsed(MODEL(self), s, NULL, a, n, batch, NULL);
        vec_arg b[2];
        if (tau != NULL && parse_arg(tau, "tau", &b[1]) == 0) {
            b[0] = a[1]; /* qd, as parsed (not released through b) */
            out = map_parsed(MODEL(self), &S_VOLTAGE_FROM_TORQUE, NULL, b, n, batch, NULL);
            arg_release(&b[1]);
        }
        Py_XDECREF(tau);
    }
    args_release(a, 3);
    return out;
}

/* Copy a C struct of `size` bytes from a buffer of exactly that size (the bytes of a packed
 * ctypes struct, e.g. CtcGains.packed); TypeError naming `what` otherwise. */
static int struct_from(PyObject *obj, void *dst, size_t size, const char *method, const char *what)
{
    Py_buffer view;
    if (PyObject_GetBuffer(obj, &view, PyBUF_SIMPLE) != 0) {
        return -1;
    }
    const int size_ok = view.len == (Py_ssize_t)size;
    if (size_ok) {
        memcpy(dst, view.buf, size);
    }
    PyBuffer_Release(&view);
    if (!size_ok) {
        PyErr_Format(PyExc_TypeError, "%s needs the %zu bytes of an %s", method, size, what);
        return -1;
    }
    return 0;
}

/* A writable buffer of exactly `size` bytes (a ctypes struct the call updates in place). */
static int writable_struct(PyObject *obj, Py_buffer *view, size_t size, const char *method,
                           const char *what)
{
    if (PyObject_GetBuffer(obj, view, PyBUF_WRITABLE) != 0) {
        if (!PyErr_ExceptionMatches(PyExc_BufferError) &&
            !PyErr_ExceptionMatches(PyExc_TypeError)) {
            return -1;
        }
        PyErr_Clear();
    } else if (view->len == (Py_ssize_t)size) {
        return 0;
    } else {
        PyBuffer_Release(view);
    }
    PyErr_Format(PyExc_TypeError, "%s needs a writable %s of %zu bytes", method, what, size);
    return -1;
}

/* The gains of the control law from the bytes of an rrr_ctc_gains (CtcGains.packed), copied. */
static int ctc_gains_from(PyObject *obj, rrr_ctc_gains *gains)
{
    return struct_from(obj, gains, sizeof *gains, "ctc", "rrr_ctc_gains (CtcGains.packed)");
}

/* ctc(gains, q_ref, qd_ref, qdd_ref, q, qd) -> (u, u_n, u_c), one state or rows. */
static PyObject *K_ctc(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    rrr_ctc_gains gains;
    if (check_nargs("ctc", nargs, 6) != 0 || ctc_gains_from(args[0], &gains) != 0) {
        return NULL;
    }
    return map_rows(MODEL(self), &S_CTC, &gains, args + 1);
}

/* ctc_jacobian(gains, q_ref, qd_ref, qdd_ref, q, qd) -> (u, du, du_n), one state or rows. */
static PyObject *K_ctc_jacobian(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    rrr_ctc_gains gains;
    if (check_nargs("ctc_jacobian", nargs, 6) != 0 ||
        struct_from(args[0], &gains, sizeof gains, "ctc_jacobian",
                    "rrr_ctc_gains (CtcGains.packed)") != 0) {
        return NULL;
    }
    return map_rows(MODEL(self), &S_CTC_JACOBIAN, &gains, args + 1);
}

/* The state error's context: "u = [...], h = ..., q = [...], qd = [...]". */
static void raise_plant(const char *fn, rrr_status st, const double *u, double h,
                        const rrr_plant_state *x)
{
    PyObject *ru = row_repr(u), *rq = row_repr(x->q), *rqd = row_repr(x->qd);
    PyObject *rh = PyFloat_FromDouble(h);
    PyObject *context = ru != NULL && rq != NULL && rqd != NULL && rh != NULL
                            ? PyUnicode_FromFormat("u = %U, h = %R, q = %U, qd = %U", ru, rh, rq,
                                                   rqd)
                            : NULL;
    Py_XDECREF(ru);
    Py_XDECREF(rq);
    Py_XDECREF(rqd);
    Py_XDECREF(rh);
    if (context != NULL) {
        raise_status(fn, (int)st, context);
        Py_DECREF(context);
    }
}

/* A (3,) result array holding v. */
static PyObject *vector_of(const double v[NJ])
{
    const Py_ssize_t dims[1] = {NJ};
    double *data;
    PyObject *out = new_array(0, 1, 1, dims, &data);
    if (out != NULL) {
        memcpy(data, v, NJ * sizeof *v);
    }
    return out;
}

/* plant_step(integrator, u, h, state, stats) -> qdd: rrr_plant_step on the rrr_plant_state in
 * the writable buffer `state` (updated in place only on success, as the C call does), the
 * rrr_plant_stats of the call written into `stats`; qdd at the end of the interval. */
static PyObject *K_plant_step(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    rrr_plant_integrator integ;
    if (check_nargs("plant_step", nargs, 5) != 0 ||
        struct_from(args[0], &integ, sizeof integ, "plant_step",
                    "rrr_plant_integrator (PlantIntegrator.packed)") != 0) {
        return NULL;
    }
    vec_arg u;
    if (one_target(args[1], "u", "plant_step takes one input voltage u (3,)", &u) != 0) {
        return NULL;
    }
    double h;
    Py_buffer sv, tv;
    PyObject *out = NULL;
    if (finite_scalar(args[2], "h", &h) == 0 &&
        writable_struct(args[3], &sv, sizeof(rrr_plant_state), "plant_step",
                        "rrr_plant_state (RawPlantState)") == 0) {
        if (writable_struct(args[4], &tv, sizeof(rrr_plant_stats), "plant_step",
                            "rrr_plant_stats (RawPlantStats)") == 0) {
            rrr_plant_state x;
            rrr_plant_stats stats;
            double qdd[NJ];
            memcpy(&x, sv.buf, sizeof x);
            const rrr_status st = rrr_plant_step(MODEL(self), &integ, u.data, h, &x, qdd, &stats);
            if (st == RRR_OK) {
                out = vector_of(qdd);
                if (out != NULL) {
                    memcpy(sv.buf, &x, sizeof x);
                    memcpy(tv.buf, &stats, sizeof stats);
                }
            } else {
                raise_plant("rrr_plant_step", st, u.data, h, &x);
            }
            PyBuffer_Release(&tv);
        }
        PyBuffer_Release(&sv);
    }
    arg_release(&u);
    return out;
}

/* plant_accel(state, u) -> qdd of the rrr_plant_state in the buffer `state` under u. */
static PyObject *K_plant_accel(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    rrr_plant_state x;
    if (check_nargs("plant_accel", nargs, 2) != 0 ||
        struct_from(args[0], &x, sizeof x, "plant_accel", "rrr_plant_state (RawPlantState)") !=
            0) {
        return NULL;
    }
    vec_arg u;
    if (one_target(args[1], "u", "plant_accel takes one input voltage u (3,)", &u) != 0) {
        return NULL;
    }
    double qdd[NJ];
    PyObject *out = NULL;
    const rrr_status st = rrr_plant_accel(MODEL(self), &x, u.data, qdd);
    if (st == RRR_OK) {
        out = vector_of(qdd);
    } else {
        raise_plant("rrr_plant_accel", st, u.data, 0.0, &x);
    }
    arg_release(&u);
    return out;
}

/* A C-contiguous, aligned buffer of native doubles, writable if asked, of `count` doubles
 * (count < 0: a whole number of rows of `width`, the rows in *rows): held in *view. -1 raised
 * (BadInputError naming fn and the argument) otherwise. */
static double *doubles_of(PyObject *obj, Py_buffer *view, Py_ssize_t count, Py_ssize_t width,
                          Py_ssize_t *rows, int writable, const char *fn, const char *name)
{
    const int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) != 0) {
        PyObject *why = raised_exception();
        PyErr_Format(g_bad_input, "%s: %s must be a%s C-contiguous float64 array: %S", fn, name,
                     writable ? " writable" : "", why);
        Py_XDECREF(why);
        return NULL;
    }
    const Py_ssize_t n = view->len / (Py_ssize_t)sizeof(double);
    int ok = view->itemsize == (Py_ssize_t)sizeof(double) && native_double_format(view->format) &&
             is_aligned(view->buf);
    if (ok && count >= 0) {
        ok = n == count;
    } else if (ok) {
        ok = n % width == 0;
        *rows = n / width;
    }
    if (!ok) {
        PyBuffer_Release(view);
        if (count >= 0) {
            PyErr_Format(g_bad_input, "%s: %s must be a C-contiguous, aligned float64 array of "
                         "%zd values", fn, name, count);
        } else {
            PyErr_Format(g_bad_input, "%s: %s must be a C-contiguous, aligned float64 array of "
                         "rows of %zd values", fn, name, width);
        }
        return NULL;
    }
    return (double *)view->buf;
}

/* plant_rollout(integrator, u, h, state, q, qd, qdd, stats) -> (status, done): rrr_plant_rollout
 * of the m rows of u (an (m, 3) float64 array) from the rrr_plant_state in the writable buffer
 * `state` (updated to the state after the last step done), q, qd, qdd: writable (m, 3) float64
 * arrays, stats: the rrr_plant_stats of the steps done. Without the GIL. rr.Plant.rollout raises
 * for a status other than RRR_OK with its own message. */
static PyObject *K_plant_rollout(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    rrr_plant_integrator integ;
    double h;
    if (check_nargs("plant_rollout", nargs, 8) != 0 ||
        struct_from(args[0], &integ, sizeof integ, "plant_rollout",
                    "rrr_plant_integrator (PlantIntegrator.packed)") != 0) {
        return NULL;
    }
    h = PyFloat_AsDouble(args[2]); /* a bad h is rrr_plant_rollout's to refuse, at row 0 */
    if (h == -1.0 && PyErr_Occurred()) {
        return NULL;
    }
    static const char *const names[4] = {"u", "q", "qd", "qdd"};
    static const int arg_of[4] = {1, 4, 5, 6};
    Py_buffer views[4], sv, tv;
    double *arrays[4];
    Py_ssize_t m = 0;
    int held = 0;
    PyObject *out = NULL;
    for (; held < 4; ++held) {
        arrays[held] = doubles_of(args[arg_of[held]], &views[held], held == 0 ? -1 : m * NJ, NJ,
                                  &m, held > 0, "plant_rollout", names[held]);
        if (arrays[held] == NULL) {
            goto done;
        }
    }
    if (writable_struct(args[3], &sv, sizeof(rrr_plant_state), "plant_rollout",
                        "rrr_plant_state (RawPlantState)") != 0) {
        goto done;
    }
    if (writable_struct(args[7], &tv, sizeof(rrr_plant_stats), "plant_rollout",
                        "rrr_plant_stats (RawPlantStats)") == 0) {
        rrr_plant_state x;
        rrr_plant_stats stats;
        size_t n_done = 0;
        rrr_status st;
        memcpy(&x, sv.buf, sizeof x);
        Py_BEGIN_ALLOW_THREADS
        st = rrr_plant_rollout(MODEL(self), &integ, (size_t)m, arrays[0], h, &x, arrays[1],
                               arrays[2], arrays[3], &n_done, &stats);
        Py_END_ALLOW_THREADS
        memcpy(sv.buf, &x, sizeof x);
        memcpy(tv.buf, &stats, sizeof stats);
        out = Py_BuildValue("(in)", (int)st, (Py_ssize_t)n_done);
        PyBuffer_Release(&tv);
    }
    PyBuffer_Release(&sv);
done:
    for (int k = 0; k < held; ++k) {
        PyBuffer_Release(&views[k]);
    }
    return out;
}

#define FASTCALL(name, doc) {#name, (PyCFunction)(void (*)(void))K_##name, METH_FASTCALL, doc}

static PyMethodDef Kernels_methods[] = {
    FASTCALL(fk, "fk(q[, path[, out]]) -> (x, R)"),
    FASTCALL(fk_frames, "fk_frames(q) -> T (4, 4, 4): DH frames 0..3 in frame 0"),
    FASTCALL(jacobian, "jacobian(q) -> J"),
    FASTCALL(tip_motion, "tip_motion(q, qd, qdd) -> (xd, xdd)"),
    FASTCALL(joint_motion, "joint_motion(q, xd, xdd) -> (qd, qdd)"),
    FASTCALL(ik, "ik(x) -> (k, 3) solutions"),
    FASTCALL(ik_branches, "ik_branches(x) -> [(shoulder, elbow), ...]"),
    FASTCALL(ik_branch, "ik_branch(x, shoulder, elbow[, path[, out]]) -> q (shoulder 0 front / "
                        "1 back, elbow 0 up / 1 down; rows by rrr_ik_batch on path)"),
    FASTCALL(ik_nearest, "ik_nearest(x, q_prev) -> q"),
    FASTCALL(singularity, "singularity(q, tol) -> (stretched, folded, shoulder, elbow_margin, "
                          "shoulder_margin, det_jacobian)"),
    FASTCALL(workspace_margin, "workspace_margin(x) -> margin"),
    FASTCALL(regressor, "regressor(q, qd, qdd[, path[, out]]) -> R"),
    FASTCALL(inverse_dynamics, "inverse_dynamics(q, qd, qdd[, path[, out]]) -> tau"),
    FASTCALL(mass_matrix, "mass_matrix(q) -> D"),
    FASTCALL(coriolis, "coriolis(q, qd) -> c"),
    FASTCALL(gravity, "gravity(q) -> h"),
    FASTCALL(forward_dynamics, "forward_dynamics(q, qd, tau[, path[, out]]) -> qdd"),
    FASTCALL(energy, "energy(q, qd) -> (kinetic, potential)"),
    FASTCALL(friction, "friction(qd) -> u_f"),
    FASTCALL(voltage_from_torque, "voltage_from_torque(qd, tau) -> u"),
    FASTCALL(torque_from_voltage, "torque_from_voltage(qd, u) -> tau"),
    FASTCALL(nominal_voltage, "nominal_voltage(q, qd, qdd) -> u_n"),
    FASTCALL(ctc, "ctc(gains, q_ref, qd_ref, qdd_ref, q, qd) -> (u, u_n, u_c)"),
    FASTCALL(plant_step, "plant_step(integrator, u, h, state, stats) -> qdd (state and stats "
                         "updated in place)"),
    FASTCALL(plant_accel, "plant_accel(state, u) -> qdd"),
    FASTCALL(plant_rollout, "plant_rollout(integrator, u, h, state, q, qd, qdd, stats) -> "
                            "(status, done): rrr_plant_rollout of the rows of u"),
    FASTCALL(plant_jacobian, "plant_jacobian(q, qd, u) -> (qdd, J), J = d qdd / d(q, qd, u) "
                             "(3, 9)"),
    FASTCALL(ctc_jacobian, "ctc_jacobian(gains, q_ref, qd_ref, qdd_ref, q, qd) -> (u, du, du_n), "
                           "du = d u / d(q_ref, qd_ref, qdd_ref, q, qd) (3, 15)"),
    {NULL, NULL, 0, NULL},
};

/* A function's address as a type slot's void * (ISO C converts no function pointer to an object
 * pointer; CPython's slots assume they have one representation, as on every platform it runs
 * on). */
static void *slot_fn(void (*fn)(void))
{
    void *p;
    _Static_assert(sizeof p == sizeof fn, "function and object pointers of one size");
    memcpy(&p, &fn, sizeof p);
    return p;
}

static PyType_Slot Kernels_slots[] = {
    {Py_tp_new, NULL},     /* Kernels_new, set by PyInit__ext */
    {Py_tp_dealloc, NULL}, /* Kernels_dealloc, likewise */
    {Py_tp_methods, Kernels_methods},
    {Py_tp_doc, (void *)"Kernels(raw): the calls of librrr on the rrr_model in the buffer of "
                        "raw (a ctypes RawModel, read in place and kept alive). Arguments are "
                        "(3,) vectors or (n, 3) batches; every method mirrors the Model method "
                        "of the same name."},
    {0, NULL},
};

static PyType_Spec Kernels_spec = {
    .name = "rrr_robot.core._ext.Kernels",
    .basicsize = sizeof(KernelsObject),
    .itemsize = 0,
    .flags = Py_TPFLAGS_DEFAULT,
    .slots = Kernels_slots,
};

/* ------------------------------------------------------------------------------------------ */
/* Module functions: the rest of librrr, on the ctypes structs of rrr_robot.core._lib           */
/* ------------------------------------------------------------------------------------------ */

/* A C struct of `size` bytes copied in from a buffer (struct_from), called on, copied back. */
#define STRUCT_IN(obj, var, fn, what) struct_from((obj), &(var), sizeof(var), (fn), (what))

/* The result of a call that fills a struct: raise its status, else None. */
static PyObject *status_result(const char *fn, rrr_status st)
{
    if (st != RRR_OK) {
        raise_status(fn, (int)st, NULL);
        return NULL;
    }
    Py_RETURN_NONE;
}

/* Fill the writable buffer `obj` (exactly `size` bytes) by `fill` on a local copy. */
#define FILL_FUNCTION(name, type, what)                                                     \
    static PyObject *E_##name(PyObject *mod, PyObject *obj)                                 \
    {                                                                                       \
        (void)mod;                                                                          \
        Py_buffer view;                                                                     \
        if (writable_struct(obj, &view, sizeof(type), #name, what) != 0) {                  \
            return NULL;                                                                    \
        }                                                                                   \
        type value;                                                                         \
        memset(&value, 0, sizeof value);                                                    \
        const rrr_status st = rrr_##name(&value);                                           \
        if (st == RRR_OK) {                                                                 \
            memcpy(view.buf, &value, sizeof value);                                         \
        }                                                                                   \
        PyBuffer_Release(&view);                                                            \
        return status_result("rrr_" #name, st);                                            \
    }

FILL_FUNCTION(model_default, rrr_model, "rrr_model (RawModel)")
FILL_FUNCTION(ctc_gains_default, rrr_ctc_gains, "rrr_ctc_gains (RawCtcGains)")
FILL_FUNCTION(plant_integrator_default, rrr_plant_integrator,
              "rrr_plant_integrator (RawPlantIntegrator)")

/* (status, field): a check's status and the field it names ("" when none). */
static PyObject *check_result(rrr_status st, const char *field)
{
    return Py_BuildValue("(is)", (int)st, st != RRR_OK && field != NULL ? field : "");
}

/* model_validate(raw) -> (status, field) of rrr_model_validate */
static PyObject *E_model_validate(PyObject *mod, PyObject *obj)
{
    (void)mod;
    rrr_model m;
    if (STRUCT_IN(obj, m, "model_validate", "rrr_model (RawModel)") != 0) {
        return NULL;
    }
    const char *field = NULL;
    const rrr_status st = rrr_model_validate(&m, &field);
    return check_result(st, field);
}

/* plant_integrator_check(raw) -> (status, field) of rrr_plant_integrator_check */
static PyObject *E_plant_integrator_check(PyObject *mod, PyObject *obj)
{
    (void)mod;
    rrr_plant_integrator s;
    if (STRUCT_IN(obj, s, "plant_integrator_check",
                  "rrr_plant_integrator (RawPlantIntegrator)") != 0) {
        return NULL;
    }
    const char *field = NULL;
    const rrr_status st = rrr_plant_integrator_check(&s, &field);
    return check_result(st, field);
}

/* plant_stiffness(raw) -> (status, lambda, field) of rrr_plant_stiffness */
static PyObject *E_plant_stiffness(PyObject *mod, PyObject *obj)
{
    (void)mod;
    rrr_model m;
    if (STRUCT_IN(obj, m, "plant_stiffness", "rrr_model (RawModel)") != 0) {
        return NULL;
    }
    double lambda = 0.0;
    const char *field = NULL;
    const rrr_status st = rrr_plant_stiffness(&m, &lambda, &field);
    return Py_BuildValue("(ids)", (int)st, lambda, field != NULL ? field : "");
}

/* bps_from_inertia(raw, inertial, p): rrr_bps_from_inertia into p (a writable float64 buffer of
 * RRR_NP values: an array, or RawModel.p) */
static PyObject *E_bps_from_inertia(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    (void)mod;
    rrr_model m;
    rrr_inertial in;
    if (check_nargs("bps_from_inertia", nargs, 3) != 0 ||
        STRUCT_IN(args[0], m, "bps_from_inertia", "rrr_model (RawModel)") != 0 ||
        STRUCT_IN(args[1], in, "bps_from_inertia", "rrr_inertial (RawInertial)") != 0) {
        return NULL;
    }
    Py_buffer view;
    double *p = doubles_of(args[2], &view, RRR_NP, 1, NULL, 1, "bps_from_inertia", "p");
    if (p == NULL) {
        return NULL;
    }
    double out[RRR_NP];
    const rrr_status st = rrr_bps_from_inertia(&m, &in, out);
    if (st == RRR_OK) {
        memcpy(p, out, sizeof out);
    }
    PyBuffer_Release(&view);
    return status_result("rrr_bps_from_inertia", st);
}

/* plant_state_init(q0, qd0, state): rrr_plant_state_init into the writable RawPlantState */
static PyObject *E_plant_state_init(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    (void)mod;
    if (check_nargs("plant_state_init", nargs, 3) != 0) {
        return NULL;
    }
    vec_arg a[2];
    static const char *const names[2] = {"q0", "qd0"};
    if (parse_args(args, 2, names, a) != 0) {
        return NULL;
    }
    PyObject *out = NULL;
    Py_buffer view;
    if (a[0].batch || a[1].batch) {
        PyErr_SetString(g_bad_input, "plant_state_init takes one q0 (3,) and one qd0 (3,)");
    } else if (writable_struct(args[2], &view, sizeof(rrr_plant_state), "plant_state_init",
                               "rrr_plant_state (RawPlantState)") == 0) {
        rrr_plant_state x;
        memset(&x, 0, sizeof x);
        const rrr_status st = rrr_plant_state_init(a[0].data, a[1].data, &x);
        if (st == RRR_OK) {
            memcpy(view.buf, &x, sizeof x);
            out = Py_NewRef(Py_None);
        } else {
            const double *rows[2] = {a[0].data, a[1].data};
            PyObject *context = rows_text(NULL, names, 2, rows);
            if (context != NULL) {
                raise_status("rrr_plant_state_init", (int)st, context);
                Py_DECREF(context);
            }
        }
        PyBuffer_Release(&view);
    }
    args_release(a, 2);
    return out;
}

/* sim_closed_loop_part(plant, integrator, q0, qd0, ctrl, gains, step, ref, plant_out, ctrl_out,
 * count, carry) -> (status, done): rrr_sim_closed_loop_part on the n rows of ref (n, 9), writing
 * plant_out (n, 12) and ctrl_out (n, 9) and the writable RawSimCarry. Without the GIL. */
static PyObject *E_sim_closed_loop_part(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    (void)mod;
    const char *fn = "sim_closed_loop_part";
    rrr_model plant, ctrl;
    rrr_plant_integrator integ;
    rrr_ctc_gains gains;
    double step;
    if (check_nargs(fn, nargs, 12) != 0 ||
        STRUCT_IN(args[0], plant, fn, "rrr_model (RawModel)") != 0 ||
        STRUCT_IN(args[1], integ, fn, "rrr_plant_integrator (RawPlantIntegrator)") != 0 ||
        STRUCT_IN(args[4], ctrl, fn, "rrr_model (RawModel)") != 0 ||
        STRUCT_IN(args[5], gains, fn, "rrr_ctc_gains (RawCtcGains)") != 0 ||
        finite_scalar(args[6], "step", &step) != 0) {
        return NULL;
    }
    const Py_ssize_t count = PyLong_AsSsize_t(args[10]);
    if (count == -1 && PyErr_Occurred()) {
        return NULL;
    }
    if (count < 1) {
        PyErr_Format(g_bad_input, "%s: count must be at least 1, got %zd", fn, count);
        return NULL;
    }
    static const char *const names[5] = {"q0", "qd0", "ref", "plant_out", "ctrl_out"};
    static const int arg_of[5] = {2, 3, 7, 8, 9};
    Py_buffer views[5];
    double *arrays[5];
    Py_ssize_t n = 0;
    int held = 0;
    PyObject *out = NULL;
    for (; held < 5; ++held) {
        const Py_ssize_t want[5] = {NJ, NJ, -1, n * RRR_SIM_PLANT_COLS, n * RRR_SIM_CTRL_COLS};
        arrays[held] = doubles_of(args[arg_of[held]], &views[held], want[held],
                                  RRR_SIM_REF_COLS, &n, held >= 3, fn, names[held]);
        if (arrays[held] == NULL) {
            goto done;
        }
    }
    Py_buffer cv;
    if (writable_struct(args[11], &cv, sizeof(rrr_sim_carry), fn,
                        "rrr_sim_carry (RawSimCarry)") == 0) {
        rrr_sim_carry carry;
        size_t n_done = 0;
        rrr_status st;
        memcpy(&carry, cv.buf, sizeof carry);
        Py_BEGIN_ALLOW_THREADS
        st = rrr_sim_closed_loop_part(&plant, &integ, arrays[0], arrays[1], &ctrl, &gains,
                                      (size_t)n, step, arrays[2], arrays[3], arrays[4],
                                      (size_t)count, &carry, &n_done);
        Py_END_ALLOW_THREADS
        memcpy(cv.buf, &carry, sizeof carry);
        out = Py_BuildValue("(in)", (int)st, (Py_ssize_t)n_done);
        PyBuffer_Release(&cv);
    }
done:
    for (int k = 0; k < held; ++k) {
        PyBuffer_Release(&views[k]);
    }
    return out;
}

/* The length of the text in a char array of `size` bytes (up to its NUL, if any). */
static Py_ssize_t text_len(const char *text, size_t size)
{
    const char *end = memchr(text, '\0', size);
    return end != NULL ? (Py_ssize_t)(end - text) : (Py_ssize_t)size;
}

/* param_table() -> ((name, unit, bound, description), ...): the rows of rrr_param_table */
static PyObject *E_param_table(PyObject *mod, PyObject *unused)
{
    (void)mod;
    (void)unused;
    size_t n = 0;
    const rrr_param_info *rows = rrr_param_table(&n);
    PyObject *out = PyTuple_New((Py_ssize_t)n);
    for (size_t i = 0; out != NULL && i < n; ++i) {
        const rrr_param_info *r = &rows[i];
        PyObject *row = Py_BuildValue("(s#s#is#)", r->name, text_len(r->name, sizeof r->name),
                                      r->unit, text_len(r->unit, sizeof r->unit), (int)r->bound,
                                      r->description,
                                      text_len(r->description, sizeof r->description));
        if (row == NULL) {
            Py_CLEAR(out);
        } else {
            PyTuple_SetItem(out, (Py_ssize_t)i, row); /* steals row */
        }
    }
    return out;
}

/* param_index(name) -> the row of name in rrr_param_table, -1 when there is none */
static PyObject *E_param_index(PyObject *mod, PyObject *obj)
{
    (void)mod;
    Py_ssize_t size;
    const char *name = PyUnicode_AsUTF8AndSize(obj, &size);
    if (name == NULL) {
        return NULL;
    }
    if ((size_t)size != strlen(name)) {
        return PyLong_FromLong(-1); /* an embedded NUL: no parameter's name */
    }
    return PyLong_FromLong(rrr_param_index(name));
}

/* A table row from a Python int: a negative one is out of range for librrr too. */
static int row_of(PyObject *obj, size_t *row)
{
    const Py_ssize_t i = PyLong_AsSsize_t(obj);
    if (i == -1 && PyErr_Occurred()) {
        return -1;
    }
    *row = i < 0 ? SIZE_MAX : (size_t)i;
    return 0;
}

/* param_get(raw, row) -> float: rrr_param_get (NaN for a row out of range) */
static PyObject *E_param_get(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    (void)mod;
    rrr_model m;
    size_t row;
    if (check_nargs("param_get", nargs, 2) != 0 ||
        STRUCT_IN(args[0], m, "param_get", "rrr_model (RawModel)") != 0 ||
        row_of(args[1], &row) != 0) {
        return NULL;
    }
    return PyFloat_FromDouble(rrr_param_get(&m, row));
}

/* param_set(raw, row, value) -> status of rrr_param_set on the writable RawModel */
static PyObject *E_param_set(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    (void)mod;
    size_t row;
    Py_buffer view;
    if (check_nargs("param_set", nargs, 3) != 0 || row_of(args[1], &row) != 0) {
        return NULL;
    }
    const double value = PyFloat_AsDouble(args[2]);
    if (value == -1.0 && PyErr_Occurred()) {
        return NULL;
    }
    if (writable_struct(args[0], &view, sizeof(rrr_model), "param_set",
                        "rrr_model (RawModel)") != 0) {
        return NULL;
    }
    rrr_model m;
    memcpy(&m, view.buf, sizeof m);
    const rrr_status st = rrr_param_set(&m, row, value);
    if (st == RRR_OK) {
        memcpy(view.buf, &m, sizeof m);
    }
    PyBuffer_Release(&view);
    return PyLong_FromLong((long)st);
}

/* param_in_range(row, value) -> bool: rrr_param_in_range */
static PyObject *E_param_in_range(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    (void)mod;
    size_t row;
    if (check_nargs("param_in_range", nargs, 2) != 0 || row_of(args[0], &row) != 0) {
        return NULL;
    }
    const double value = PyFloat_AsDouble(args[1]);
    if (value == -1.0 && PyErr_Occurred()) {
        return NULL;
    }
    return PyBool_FromLong(rrr_param_in_range(row, value));
}

/* simd_available(path) -> bool: rrr_simd_available for an rrr_simd value */
static PyObject *E_simd_available(PyObject *mod, PyObject *obj)
{
    (void)mod;
    const long v = PyLong_AsLong(obj);
    if (v == -1 && PyErr_Occurred()) {
        return NULL;
    }
    return PyBool_FromLong(v >= RRR_SIMD_AUTO && v <= RRR_SIMD_AVX512 &&
                           rrr_simd_available((rrr_simd)v));
}

/* simd_best() -> the rrr_simd value "auto" means here */
static PyObject *E_simd_best(PyObject *mod, PyObject *unused)
{
    (void)mod;
    (void)unused;
    return PyLong_FromLong((long)rrr_simd_best());
}

#define FAST(name, doc) {#name, (PyCFunction)(void (*)(void))E_##name, METH_FASTCALL, doc}
#define ONE(name, doc) {#name, (PyCFunction)(void (*)(void))E_##name, METH_O, doc}
#define NONE(name, doc) {#name, (PyCFunction)(void (*)(void))E_##name, METH_NOARGS, doc}

static PyMethodDef ext_functions[] = {
    ONE(model_default, "model_default(raw): rrr_model_default into a RawModel"),
    ONE(ctc_gains_default, "ctc_gains_default(raw): rrr_ctc_gains_default into a RawCtcGains"),
    ONE(plant_integrator_default, "plant_integrator_default(raw): rrr_plant_integrator_default "
                                  "into a RawPlantIntegrator"),
    ONE(model_validate, "model_validate(raw) -> (status, field) of rrr_model_validate"),
    ONE(plant_integrator_check, "plant_integrator_check(raw) -> (status, field) of "
                                "rrr_plant_integrator_check"),
    ONE(plant_stiffness, "plant_stiffness(raw) -> (status, lambda, field) of "
                         "rrr_plant_stiffness"),
    FAST(bps_from_inertia, "bps_from_inertia(raw, inertial, p): rrr_bps_from_inertia into p"),
    FAST(plant_state_init, "plant_state_init(q0, qd0, state): rrr_plant_state_init into a "
                           "RawPlantState"),
    FAST(sim_closed_loop_part, "sim_closed_loop_part(plant, integrator, q0, qd0, ctrl, gains, "
                               "step, ref, plant_out, ctrl_out, count, carry) -> (status, "
                               "done)"),
    NONE(param_table, "param_table() -> ((name, unit, bound, description), ...)"),
    ONE(param_index, "param_index(name) -> row, -1 when there is none"),
    FAST(param_get, "param_get(raw, row) -> value"),
    FAST(param_set, "param_set(raw, row, value) -> status"),
    FAST(param_in_range, "param_in_range(row, value) -> bool"),
    ONE(simd_available, "simd_available(path) -> bool"),
    NONE(simd_best, "simd_best() -> the rrr_simd value of 'auto' here"),
    {NULL, NULL, 0, NULL},
};

/* ------------------------------------------------------------------------------------------ */
/* Module                                                                                     */
/* ------------------------------------------------------------------------------------------ */

static int import_dependencies(void)
{
    g_empty = attr_of("numpy", "empty");
    g_as_rows = attr_of("rrr_robot.core._arrays", "as_rows");
    g_rrr_error = attr_of("rrr_robot.errors", "RrrError");
    g_bad_input = attr_of("rrr_robot.errors", "BadInputError");
    PyObject *names = attr_of("rrr_robot.core._status", "STATUS_NAMES");
    g_status_errors = attr_of("rrr_robot.core._status", "ERRORS");
    g_status_meaning = attr_of("rrr_robot.core._status", "MEANING");
    if (g_empty == NULL || g_as_rows == NULL || g_rrr_error == NULL || g_bad_input == NULL ||
        names == NULL || g_status_errors == NULL || g_status_meaning == NULL) {
        Py_XDECREF(names);
        return -1;
    }
    g_status_names = PySequence_Tuple(names);
    Py_DECREF(names);
    if (g_status_names == NULL) {
        return -1;
    }
    if (!PyDict_Check(g_status_errors) || !PyDict_Check(g_status_meaning)) {
        PyErr_SetString(PyExc_ImportError,
                        "rrr_robot.core._status: ERRORS and MEANING must be dicts");
        return -1;
    }
    static const char *const simd_names[] = {"auto", "scalar", "avx2", "avx512"};
    _Static_assert(sizeof simd_names / sizeof simd_names[0] == RRR_SIMD_AVX512 + 1,
                   "a name for each rrr_simd value");
    for (int v = RRR_SIMD_AUTO; v <= RRR_SIMD_AVX512; ++v) {
        g_simd_names[v] = PyUnicode_InternFromString(simd_names[v]);
        if (g_simd_names[v] == NULL) {
            return -1;
        }
    }
    /* branch index = shoulder * 2 + elbow (rrr_kinematics.h) */
    g_branch_names = Py_BuildValue("((ss)(ss)(ss)(ss))", "front", "up", "front", "down", "back",
                                   "up", "back", "down");
    return g_branch_names != NULL ? 0 : -1;
}

static struct PyModuleDef ext_module = {
    PyModuleDef_HEAD_INIT,
    .m_name = "rrr_robot.core._ext",
    .m_doc = "The compiled binding of librrr: Kernels (Model's calls) and the module functions "
             "on the ctypes structs of rrr_robot.core._lib.",
    .m_size = -1,
    .m_methods = ext_functions,
};

/* {struct name: sizeof}: what the ctypes mirrors of rrr_robot.core._lib must measure */
static PyObject *struct_sizes(void)
{
    return Py_BuildValue(
        "{snsnsnsnsnsnsnsnsn}", "rrr_model", (Py_ssize_t)sizeof(rrr_model), "rrr_inertial",
        (Py_ssize_t)sizeof(rrr_inertial), "rrr_ik_set", (Py_ssize_t)sizeof(rrr_ik_set),
        "rrr_ctc_gains", (Py_ssize_t)sizeof(rrr_ctc_gains), "rrr_plant_integrator",
        (Py_ssize_t)sizeof(rrr_plant_integrator), "rrr_plant_state",
        (Py_ssize_t)sizeof(rrr_plant_state), "rrr_plant_stats", (Py_ssize_t)sizeof(rrr_plant_stats),
        "rrr_sim_carry", (Py_ssize_t)sizeof(rrr_sim_carry), "rrr_singularity",
        (Py_ssize_t)sizeof(rrr_singularity));
}

PyMODINIT_FUNC PyInit__ext(void);

PyMODINIT_FUNC PyInit__ext(void)
{
    if (import_dependencies() != 0) {
        return NULL;
    }
    PyObject *m = PyModule_Create(&ext_module);
    if (m == NULL) {
        return NULL;
    }
    Kernels_slots[0].pfunc = slot_fn((void (*)(void))Kernels_new);
    Kernels_slots[1].pfunc = slot_fn((void (*)(void))Kernels_dealloc);
    PyObject *kernels = PyType_FromSpec(&Kernels_spec);
    PyObject *sizes = struct_sizes();
    PyObject *sample_time = PyFloat_FromDouble(rrr_sample_time_default());
    const char *version = rrr_version();
    const int failed =
        kernels == NULL || sizes == NULL || sample_time == NULL ||
        PyModule_AddObjectRef(m, "Kernels", kernels) != 0 ||
        PyModule_AddObjectRef(m, "SIZES", sizes) != 0 ||
        PyModule_AddObjectRef(m, "SAMPLE_TIME_DEFAULT", sample_time) != 0 ||
        PyModule_AddIntConstant(m, "NOGIL_ROWS", RRR_EXT_NOGIL_ROWS) != 0 ||
        PyModule_AddIntConstant(m, "NP", RRR_NP) != 0 ||
        PyModule_AddStringConstant(m, "VERSION", version != NULL ? version : "") != 0;
    Py_XDECREF(kernels);
    Py_XDECREF(sizes);
    Py_XDECREF(sample_time);
    if (failed) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
