/* FMI 2.0 co-simulation binary of twmr-cosim's Python FMUs (`twmr export --python`).
 *
 * It runs a pythonfmu `Fmi2Slave` subclass (resources/<module>.py, class named in
 * resources/slaveclass.txt) inside the Python interpreter of the host process, and replaces
 * pythonfmu's prebuilt binary, whose class lookup releases a reference it does not own (the
 * module's dict, a borrowed reference) on every fmi2Instantiate: the heap is corrupted and the
 * host crashes at exit or at the next instance. Here every reference is owned and released once.
 *
 * Python is not linked: its functions are weak symbols resolved in the host process. A host
 * that is not a Python process gets a clear message through its logger, not a load failure.
 * All the logic that can be Python is Python (LOADER below); this file only converts values.
 * Compiled at export time by twmr.fmi.export with the machine's C compiler.
 */
#define PY_SSIZE_T_CLEAN
#define Py_LIMITED_API 0x03080000
#include <Python.h>

#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

/* Every Python symbol used: weak, so this library loads in any host (both names of the
 * variadic calls: PY_SSIZE_T_CLEAN maps them to the _SizeT ones in some Python versions). */
#pragma weak PyBool_FromLong
#pragma weak PyBytes_AsString
#pragma weak PyDict_GetItemString
#pragma weak PyDict_New
#pragma weak PyDict_SetItemString
#pragma weak PyErr_Clear
#pragma weak PyErr_Fetch
#pragma weak PyErr_NormalizeException
#pragma weak PyErr_Occurred
#pragma weak PyEval_EvalCode
#pragma weak PyEval_GetBuiltins
#pragma weak PyFloat_AsDouble
#pragma weak PyFloat_FromDouble
#pragma weak PyGILState_Ensure
#pragma weak PyGILState_Release
#pragma weak PyList_GetItem
#pragma weak PyList_New
#pragma weak PyList_SetItem
#pragma weak PyList_Size
#pragma weak PyLong_AsLong
#pragma weak PyLong_FromLong
#pragma weak PyLong_FromUnsignedLong
#pragma weak PyObject_CallFunction
#pragma weak PyObject_CallMethod
#pragma weak PyObject_IsTrue
#pragma weak PyTuple_GetItem
#pragma weak PyUnicode_AsUTF8String
#pragma weak PyUnicode_FromString
#pragma weak Py_CompileString
#pragma weak Py_DecRef
#pragma weak Py_IncRef
#pragma weak Py_IsInitialized
#pragma weak _PyObject_CallFunction_SizeT
#pragma weak _PyObject_CallMethod_SizeT
#pragma weak _Py_NoneStruct

static const char LOADER[] =
"import sys\n"
"import traceback\n"
"\n"
"def resources_path(uri):\n"
"    from urllib.parse import unquote, urlparse\n"
"    from urllib.request import url2pathname\n"
"    p = urlparse(uri)\n"
"    return url2pathname(unquote(p.path)) if p.scheme == 'file' else uri\n"
"\n"
"def slave_class(resources):\n"
"    import hashlib, importlib.util, os\n"
"    def read(name):\n"
"        with open(os.path.join(resources, name)) as f:\n"
"            return f.read().strip()\n"
"    module = read('slavemodule.txt')\n"
"    key = '_twmr_fmu_' + hashlib.sha1(os.path.abspath(resources).encode()).hexdigest()[:16]\n"
"    mod = sys.modules.get(key)\n"
"    if mod is None:\n"
"        if resources not in sys.path:\n"
"            sys.path.insert(0, resources)\n"
"        spec = importlib.util.spec_from_file_location(key, os.path.join(resources, module + '.py'))\n"
"        mod = importlib.util.module_from_spec(spec)\n"
"        sys.modules[key] = mod\n"
"        try:\n"
"            spec.loader.exec_module(mod)\n"
"        except BaseException:\n"
"            del sys.modules[key]\n"
"            raise\n"
"    if os.path.exists(os.path.join(resources, 'slaveclass.txt')):\n"
"        return getattr(mod, read('slaveclass.txt'))\n"
"    from pythonfmu import Fmi2Slave\n"
"    found = [c for c in vars(mod).values() if isinstance(c, type) and\n"
"             issubclass(c, Fmi2Slave) and c.__module__ == key]\n"
"    if not found:\n"
"        raise TypeError(f'{module}.py defines no subclass of pythonfmu.Fmi2Slave')\n"
"    return max(found, key=lambda c: len(c.__mro__))\n"
"\n"
"def instantiate(uri, name, visible):\n"
"    resources = resources_path(uri)\n"
"    try:\n"
"        cls = slave_class(resources)\n"
"    except ModuleNotFoundError as err:\n"
"        top = (err.name or '').split('.')[0]\n"
"        if top in ('twmr', 'pythonfmu'):\n"
"            raise ModuleNotFoundError(\n"
"                f'this FMU needs Python with twmr-cosim installed (pip install -e . in a checkout of twmr-cosim); '\n"
"                f\"the FMU's Python is {sys.executable} (it cannot import {err.name!r})\",\n"
"                name=err.name) from None\n"
"        raise ModuleNotFoundError(\n"
"            f\"the FMU's Python ({sys.executable}) cannot import {err.name!r}, which the FMU \"\n"
"            f'needs: install it there', name=err.name) from None\n"
"    return cls(instance_name=name, resources=resources, visible=visible)\n"
"\n"
"def describe(kind, value, tb):\n"
"    if isinstance(value, ModuleNotFoundError):\n"
"        return str(value)\n"
"    return ''.join(traceback.format_exception(kind, value, tb)).strip()\n"
"\n"
"def drain(slave):\n"
"    queue = slave._get_log_queue()\n"
"    out = [(int(m.status), m.category or '', str(m.msg)) for m in queue]\n"
"    del queue[:]\n"
"    return out\n"
"\n"
"def strings(values):\n"
"    return [str(v).encode() for v in values]\n"
"\n"
"def reset(slave):\n"
"    return type(slave)(instance_name=slave.instance_name, resources=slave.resources,\n"
"                       visible=slave.visible)\n";

typedef struct {
    PyObject* slave;
    char* name;
    const fmi2CallbackFunctions* functions;
    int logging;
    PyObject* strings; /* bytes of the last fmi2GetString, alive until the next call */
} Instance;

/* The loader's namespace: created under the GIL at the first instance, kept for the process. */
static PyObject* loader = NULL;

static void log_message(const fmi2CallbackFunctions* fn, const char* name, fmi2Status status,
                        const char* category, const char* message)
{
    if (fn && fn->logger) {
        fn->logger(fn->componentEnvironment, name, status, category, message);
    }
}

static PyObject* loader_function(const char* name)
{
    if (!loader) {
        PyObject* code = Py_CompileString(LOADER, "<twmr fmu loader>", Py_file_input);
        if (!code) return NULL;
        PyObject* ns = PyDict_New();
        if (!ns || PyDict_SetItemString(ns, "__builtins__", PyEval_GetBuiltins()) != 0) {
            Py_DecRef(code);
            Py_DecRef(ns);
            return NULL;
        }
        PyObject* result = PyEval_EvalCode(code, ns, ns);
        Py_DecRef(code);
        if (!result) {
            Py_DecRef(ns);
            return NULL;
        }
        Py_DecRef(result);
        loader = ns;
    }
    return PyDict_GetItemString(loader, name); /* borrowed */
}

/* Log the pending Python exception (GIL held) with `what`; clears it. */
static void log_exception(const fmi2CallbackFunctions* fn, const char* name, const char* what)
{
    PyObject *kind = NULL, *value = NULL, *tb = NULL;
    PyErr_Fetch(&kind, &value, &tb);
    PyErr_NormalizeException(&kind, &value, &tb);
    PyObject* describe = loader_function("describe");
    PyObject* text = describe ? PyObject_CallFunction(describe, "OOO", kind ? kind : Py_None,
                                                      value ? value : Py_None,
                                                      tb ? tb : Py_None) : NULL;
    PyObject* utf8 = text ? PyUnicode_AsUTF8String(text) : NULL;
    const char* body = utf8 ? PyBytes_AsString(utf8) : "(the Python error could not be shown)";
    size_t size = strlen(what) + strlen(body) + 16;
    char* message = malloc(size);
    if (message) {
        snprintf(message, size, "%s failed: %s", what, body);
        log_message(fn, name, fmi2Error, "logStatusError", message);
        free(message);
    }
    PyErr_Clear();
    Py_DecRef(utf8);
    Py_DecRef(text);
    Py_DecRef(kind);
    Py_DecRef(value);
    Py_DecRef(tb);
}

/* Forward the slave's queued log messages to the host (GIL held). */
static void forward_log(Instance* inst)
{
    PyObject* drain = loader_function("drain");
    PyObject* messages = drain ? PyObject_CallFunction(drain, "O", inst->slave) : NULL;
    if (!messages) {
        PyErr_Clear();
        return;
    }
    Py_ssize_t n = PyList_Size(messages);
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject* item = PyList_GetItem(messages, i);
        long status = PyLong_AsLong(PyTuple_GetItem(item, 0));
        PyObject* category = PyUnicode_AsUTF8String(PyTuple_GetItem(item, 1));
        PyObject* text = PyUnicode_AsUTF8String(PyTuple_GetItem(item, 2));
        if (category && text && (inst->logging || status > fmi2OK)) {
            log_message(inst->functions, inst->name, (fmi2Status)status,
                        PyBytes_AsString(category), PyBytes_AsString(text));
        }
        Py_DecRef(category);
        Py_DecRef(text);
    }
    PyErr_Clear();
    Py_DecRef(messages);
}

/* After a call on the slave (GIL held): log, then its status (`result` is consumed). */
static fmi2Status finish(Instance* inst, PyObject* result, const char* what)
{
    fmi2Status status = fmi2OK;
    if (!result) {
        log_exception(inst->functions, inst->name, what);
        status = fmi2Error;
    }
    forward_log(inst);
    Py_DecRef(result);
    return status;
}

static PyObject* references(const fmi2ValueReference vr[], size_t nvr)
{
    PyObject* list = PyList_New((Py_ssize_t)nvr);
    for (size_t i = 0; list && i < nvr; i++) {
        PyList_SetItem(list, (Py_ssize_t)i, PyLong_FromUnsignedLong(vr[i]));
    }
    return list;
}

/* ---- instances ------------------------------------------------------------------------------ */

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions* functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    const char* name = instanceName ? instanceName : "";
    (void)fmuGUID;
    if (fmuType != fmi2CoSimulation) {
        log_message(functions, name, fmi2Error, "logStatusError",
                    "fmi2Instantiate failed: this FMU is for co-simulation only");
        return NULL;
    }
    if (!Py_IsInitialized || !Py_IsInitialized()) {
        log_message(functions, name, fmi2Error, "logStatusError",
                    "fmi2Instantiate failed: this FMU runs Python code inside its host, and "
                    "the host is not a Python process: load it from Python with twmr-cosim "
                    "installed (e.g. with fmpy), or export the block as a C FMU (twmr export)");
        return NULL;
    }
    if (!fmuResourceLocation) {
        log_message(functions, name, fmi2Error, "logStatusError",
                    "fmi2Instantiate failed: no fmuResourceLocation given");
        return NULL;
    }
    Instance* inst = calloc(1, sizeof(Instance));
    if (!inst || !(inst->name = malloc(strlen(name) + 1))) {
        free(inst);
        return NULL;
    }
    strcpy(inst->name, name);
    inst->functions = functions;
    inst->logging = loggingOn;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject* make = loader_function("instantiate");
    inst->slave = make ? PyObject_CallFunction(make, "ssi", fmuResourceLocation, name,
                                               (int)visible) : NULL;
    if (!inst->slave) {
        log_exception(functions, name, "fmi2Instantiate");
        PyGILState_Release(gil);
        free(inst->name);
        free(inst);
        return NULL;
    }
    forward_log(inst);
    PyGILState_Release(gil);
    return inst;
}

void fmi2FreeInstance(fmi2Component c)
{
    Instance* inst = c;
    if (!inst) return;
    PyGILState_STATE gil = PyGILState_Ensure();
    Py_DecRef(inst->strings);
    Py_DecRef(inst->slave);
    PyGILState_Release(gil);
    free(inst->name);
    free(inst);
}

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories;
    (void)categories;
    ((Instance*)c)->logging = loggingOn;
    return fmi2OK;
}

static PyObject* optional_real(fmi2Boolean defined, fmi2Real value)
{
    if (defined) return PyFloat_FromDouble(value);
    Py_IncRef(Py_None);
    return Py_None;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    Instance* inst = c;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject* stop = optional_real(stopTimeDefined, stopTime);
    PyObject* tol = optional_real(toleranceDefined, tolerance);
    PyObject* result = stop && tol ? PyObject_CallMethod(inst->slave, "setup_experiment",
                                                         "dOO", startTime, stop, tol) : NULL;
    Py_DecRef(stop);
    Py_DecRef(tol);
    fmi2Status status = finish(inst, result, "fmi2SetupExperiment");
    PyGILState_Release(gil);
    return status;
}

/* slave.<method>() for the FMI call `what`. */
static fmi2Status call_method(fmi2Component c, const char* what, const char* method)
{
    Instance* inst = c;
    PyGILState_STATE gil = PyGILState_Ensure();
    fmi2Status status = finish(inst, PyObject_CallMethod(inst->slave, method, NULL), what);
    PyGILState_Release(gil);
    return status;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    return call_method(c, "fmi2EnterInitializationMode", "enter_initialization_mode");
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    return call_method(c, "fmi2ExitInitializationMode", "exit_initialization_mode");
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    return call_method(c, "fmi2Terminate", "terminate");
}

fmi2Status fmi2Reset(fmi2Component c)
{
    Instance* inst = c;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject* reset = loader_function("reset");
    PyObject* fresh = reset ? PyObject_CallFunction(reset, "O", inst->slave) : NULL;
    fmi2Status status = fmi2OK;
    if (fresh) {
        Py_DecRef(inst->slave);
        inst->slave = fresh;
        forward_log(inst);
    } else {
        status = finish(inst, NULL, "fmi2Reset");
    }
    PyGILState_Release(gil);
    return status;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    Instance* inst = c;
    (void)noSetFMUStatePriorToCurrentPoint;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject* result = PyObject_CallMethod(inst->slave, "do_step", "dd",
                                           currentCommunicationPoint, communicationStepSize);
    int accepted = result ? PyObject_IsTrue(result) : 0;
    fmi2Status status = finish(inst, result, "fmi2DoStep");
    if (status == fmi2OK && accepted != 1) {
        log_message(inst->functions, inst->name, fmi2Discard, "logStatusDiscard",
                    "fmi2DoStep: the slave's do_step returned False (step discarded)");
        status = fmi2Discard;
    }
    PyGILState_Release(gil);
    return status;
}

/* ---- values --------------------------------------------------------------------------------- */

/* `values` (a new list of nvr items, or NULL) passed to slave.set_<kind>(vrs, values). */
static fmi2Status set_values(Instance* inst, const char* what, const char* method,
                             const fmi2ValueReference vr[], size_t nvr, PyObject* values)
{
    PyObject* vrs = references(vr, nvr);
    PyObject* result = vrs && values && !PyErr_Occurred() ?
        PyObject_CallMethod(inst->slave, method, "OO", vrs, values) : NULL;
    Py_DecRef(vrs);
    Py_DecRef(values);
    return finish(inst, result, what);
}

/* slave.get_<kind>(vrs): a new list of nvr items, or NULL with the error logged. */
static PyObject* get_values(Instance* inst, const char* what, const char* method,
                            const fmi2ValueReference vr[], size_t nvr)
{
    PyObject* vrs = references(vr, nvr);
    PyObject* list = vrs ? PyObject_CallMethod(inst->slave, method, "O", vrs) : NULL;
    Py_DecRef(vrs);
    if (list && PyList_Size(list) != (Py_ssize_t)nvr) {
        Py_DecRef(list);
        list = NULL;
        if (!PyErr_Occurred()) {
            log_message(inst->functions, inst->name, fmi2Error, "logStatusError",
                        "the slave returned a wrong number of values");
        }
    }
    if (!list && PyErr_Occurred()) log_exception(inst->functions, inst->name, what);
    forward_log(inst);
    return list;
}

/* After converting a got list (GIL held): its status; the list is released. */
static fmi2Status got(Instance* inst, const char* what, PyObject* list)
{
    Py_DecRef(list);
    if (PyErr_Occurred()) {
        log_exception(inst->functions, inst->name, what);
        return fmi2Error;
    }
    return fmi2OK;
}

#define SETTER(FMI, CTYPE, METHOD, CONVERT)                                                    \
    fmi2Status FMI(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,                \
                   const CTYPE value[])                                                       \
    {                                                                                         \
        Instance* inst = c;                                                                   \
        PyGILState_STATE gil = PyGILState_Ensure();                                           \
        PyObject* values = PyList_New((Py_ssize_t)nvr);                                       \
        for (size_t i = 0; values && i < nvr; i++) {                                          \
            PyList_SetItem(values, (Py_ssize_t)i, CONVERT(value[i]));                         \
        }                                                                                     \
        fmi2Status status = set_values(inst, #FMI, METHOD, vr, nvr, values);                  \
        PyGILState_Release(gil);                                                              \
        return status;                                                                        \
    }

SETTER(fmi2SetReal, fmi2Real, "set_real", PyFloat_FromDouble)
SETTER(fmi2SetInteger, fmi2Integer, "set_integer", PyLong_FromLong)
SETTER(fmi2SetBoolean, fmi2Boolean, "set_boolean", PyBool_FromLong)
SETTER(fmi2SetString, fmi2String, "set_string", PyUnicode_FromString)

#define GETTER(FMI, CTYPE, METHOD, CONVERT)                                                    \
    fmi2Status FMI(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, CTYPE value[]) \
    {                                                                                         \
        Instance* inst = c;                                                                   \
        PyGILState_STATE gil = PyGILState_Ensure();                                           \
        PyObject* list = get_values(inst, #FMI, METHOD, vr, nvr);                             \
        fmi2Status status = fmi2Error;                                                        \
        if (list) {                                                                           \
            for (size_t i = 0; i < nvr; i++) {                                                \
                value[i] = (CTYPE)CONVERT(PyList_GetItem(list, (Py_ssize_t)i));               \
            }                                                                                 \
            status = got(inst, #FMI, list);                                                   \
        }                                                                                     \
        PyGILState_Release(gil);                                                              \
        return status;                                                                        \
    }

GETTER(fmi2GetReal, fmi2Real, "get_real", PyFloat_AsDouble)
GETTER(fmi2GetInteger, fmi2Integer, "get_integer", PyLong_AsLong)
GETTER(fmi2GetBoolean, fmi2Boolean, "get_boolean", PyObject_IsTrue)

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[])
{
    Instance* inst = c;
    PyGILState_STATE gil = PyGILState_Ensure();
    PyObject* list = get_values(inst, "fmi2GetString", "get_string", vr, nvr);
    PyObject* encode = list ? loader_function("strings") : NULL;
    PyObject* bytes = encode ? PyObject_CallFunction(encode, "O", list) : NULL;
    Py_DecRef(list);
    fmi2Status status = fmi2Error;
    if (bytes) {
        Py_DecRef(inst->strings); /* the previous call's strings are released now */
        inst->strings = bytes;
        for (size_t i = 0; i < nvr; i++) {
            value[i] = PyBytes_AsString(PyList_GetItem(bytes, (Py_ssize_t)i));
        }
        status = got(inst, "fmi2GetString", NULL);
    } else if (list) {
        log_exception(inst->functions, inst->name, "fmi2GetString");
    }
    PyGILState_Release(gil);
    return status;
}

/* ---- what this FMU does not support (its model description says so) ------------------------ */

static fmi2Status unsupported(fmi2Component c, const char* what)
{
    Instance* inst = c;
    char message[160];
    snprintf(message, sizeof message, "%s is not supported by this FMU", what);
    log_message(inst ? inst->functions : NULL, inst ? inst->name : "", fmi2Error,
                "logStatusError", message);
    return fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* s)
{
    (void)s;
    return unsupported(c, "fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s)
{
    (void)s;
    return unsupported(c, "fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* s)
{
    (void)s;
    return unsupported(c, "fmi2FreeFMUstate");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t* size)
{
    (void)s;
    (void)size;
    return unsupported(c, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
{
    (void)s;
    (void)b;
    (void)n;
    return unsupported(c, "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n,
                                   fmi2FMUstate* s)
{
    (void)b;
    (void)n;
    (void)s;
    return unsupported(c, "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[],
                                        size_t nu, const fmi2ValueReference z[], size_t nz,
                                        const fmi2Real dv[], fmi2Real dz[])
{
    (void)u, (void)nu, (void)z, (void)nz, (void)dv, (void)dz;
    return unsupported(c, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    return unsupported(c, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return unsupported(c, "fmi2CancelStep");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status* value)
{
    (void)k, (void)value;
    return unsupported(c, "fmi2GetStatus");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real* value)
{
    (void)k, (void)value;
    return unsupported(c, "fmi2GetRealStatus");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer* value)
{
    (void)k, (void)value;
    return unsupported(c, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean* value)
{
    (void)k, (void)value;
    return unsupported(c, "fmi2GetBooleanStatus");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String* value)
{
    (void)k, (void)value;
    return unsupported(c, "fmi2GetStringStatus");
}
