/* One state through a compiled kernel, with as little Python in between as possible.
 *
 * call(addr, shape, g, p, a[, b[, c]]) -> ndarray or None
 *
 * addr:  address of a numba cfunc  int32 k(double *a, double *b, double *c,
 *                                          double *p, double g, double *out)
 *        (exoleg.dynamics.single builds them from the generated kernels);
 * shape: 0 -> out (3,), 1 -> out (3, 3), 2 -> out (8, 2);
 * g:     gravity, m/s^2 (a float);
 * p:     the leg's parameter vector, float64 (N_PARAMS,): 5 per link, then 3 armatures;
 * a, b, c: one state each, float64 (3,).
 *
 * Returns None, without raising, when an argument is not a C-contiguous native
 * float64 array of the expected length or when the kernel reports a non-finite
 * result: the caller then takes its general path, which converts what it can
 * and names what is wrong. No physics here: the kernels are numba's.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <numpy/arrayobject.h>

/* exoleg.dynamics._generated.N_PARAMS; tests/unit/test_model.py checks they agree */
#define N_PARAMS 18

typedef int (*kernel_t)(double *, double *, double *, double *, double, double *);

static double *vector_data(PyObject *o, npy_intp n)
{
    PyArrayObject *a;
    if (!PyArray_Check(o))
        return NULL;
    a = (PyArrayObject *)o;
    if (PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 1 || PyArray_DIM(a, 0) != n
        || !PyArray_IS_C_CONTIGUOUS(a) || !PyArray_ISALIGNED(a) || !PyArray_ISNOTSWAPPED(a))
        return NULL;
    return (double *)PyArray_DATA(a);
}

static PyObject *call(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const npy_intp shapes[3][2] = {{3, 0}, {3, 3}, {8, 2}};
    double *x[3] = {NULL, NULL, NULL};
    double *p, g;
    void *addr;
    long shape;
    Py_ssize_t i;
    PyObject *out;
    (void)self;

    if (nargs < 5 || nargs > 7) {
        PyErr_SetString(PyExc_TypeError, "call(addr, shape, g, p, a[, b[, c]])");
        return NULL;
    }
    addr = PyLong_AsVoidPtr(args[0]);
    shape = PyLong_AsLong(args[1]);
    g = PyFloat_AsDouble(args[2]);
    if (PyErr_Occurred())
        return NULL;
    if (addr == NULL || shape < 0 || shape > 2) {
        PyErr_SetString(PyExc_ValueError, "call: bad kernel address or shape code");
        return NULL;
    }
    p = vector_data(args[3], N_PARAMS);
    if (p == NULL)
        Py_RETURN_NONE;
    for (i = 4; i < nargs; i++) {
        x[i - 4] = vector_data(args[i], 3);
        if (x[i - 4] == NULL)
            Py_RETURN_NONE;
    }
    out = PyArray_SimpleNew(shape == 0 ? 1 : 2, (npy_intp *)shapes[shape], NPY_DOUBLE);
    if (out == NULL)
        return NULL;
    if (!((kernel_t)addr)(x[0], x[1], x[2], p, g, (double *)PyArray_DATA((PyArrayObject *)out))) {
        Py_DECREF(out);
        Py_RETURN_NONE;
    }
    return out;
}

static PyMethodDef methods[] = {
    {"call", (PyCFunction)(void (*)(void))call, METH_FASTCALL,
     "call(addr, shape, g, p, a[, b[, c]]) -> ndarray or None: one state through a kernel."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_onecall",
    "Calls a compiled kernel on one state with minimal overhead (see exoleg.dynamics.single).",
    -1, methods,
};

PyMODINIT_FUNC PyInit__onecall(void)
{
    PyObject *m;
    import_array();
    m = PyModule_Create(&module);
    if (m != NULL && PyModule_AddIntConstant(m, "N_PARAMS", N_PARAMS) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
