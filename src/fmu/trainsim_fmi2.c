/* trainsim_fmi2.c: a train as an FMI 2.0 co-simulation FMU (issue 24; docs/fmu.md).
 *
 * The FMU's binary: the FMI 2.0 functions over trainsim's C interface (trainsim.h). The
 * deck travels in the FMU's resources (deck.nml) with the list of input nodes
 * (inputs.txt, one node id a line) and of parameters (parameters.txt, "PATH<TAB>VALUE" a
 * line), both written by `trainsim fmu`. Value references (the same rule as the
 * modelDescription.xml that `trainsim fmu` writes):
 *   node k (0-based, deck order): angle 1 + 2k, speed 2 + 2k        (outputs)
 *   input j: the torque on its node, 1000000 + j                   (inputs)
 *   parameter p: its deck path, 2000000 + p                        (parameters)
 * doStep advances a session (trainsim_session_*): trainsim's own integrator with its
 * event location inside each communication step; an input is held constant over a step
 * and acts as a load step at the communication point. get/setFMUState save and restore a
 * session point (a restored FMU continues bit for bit as it did after the save). */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_abi.h"
#include "trainsim.h"

enum { VR_INPUT = 1000000, VR_PARAM = 2000000 };

typedef struct {
    double time;
    double *inputs;
} saved_point;

typedef struct {
    trainsim_sim *sim;
    char *name;
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    char dir[4096];
    size_t n_nodes, n_inputs, n_params, n_saved;
    char **inputs, **params;
    double *input_value, *param_value, *theta, *omega;
    saved_point *saved;
    double time;
    int started, terminated;
} fmu;

static void say(fmu *c, fmi2Status status, const char *category, const char *fmt, ...) {
    char msg[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (c && c->logger) c->logger(c->env, c->name ? c->name : "trainsim", status, category, "%s", msg);
}

/* trainsim's message of the handle's last call, as an fmi2Error. */
static fmi2Status failed(fmu *c, const char *what) {
    char msg[4096];
    trainsim_error_message(c->sim, msg, sizeof msg);
    say(c, fmi2Error, "logStatusError", "%s: %s", what, msg);
    return fmi2Error;
}

static char *dup(const char *s) {
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

/* The directory of a file: URI (file:///a/b, file:/a/b, or a plain path), %XX decoded. */
static int uri_to_dir(const char *uri, char *out, size_t size) {
    const char *p = uri;
    size_t n = 0;
    if (!uri) return 0;
    if (strncmp(p, "file://", 7) == 0) p += 7;
    else if (strncmp(p, "file:", 5) == 0) p += 5;
    for (; *p && n + 1 < size; ++p) {
        if (p[0] == '%' && p[1] && p[2]) {
            char hex[3] = {p[1], p[2], 0};
            out[n++] = (char)strtol(hex, NULL, 16);
            p += 2;
        } else {
            out[n++] = *p;
        }
    }
    while (n > 1 && out[n - 1] == '/') --n;
    out[n] = 0;
    return n > 0;
}

/* The lines of resources/<name> (NULL-free, no newline); the count in *n. */
static char **read_lines(const char *dir, const char *name, size_t *n) {
    char path[4400], line[4096];
    char **lines = NULL;
    *n = 0;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "r");
    if (!f) return NULL;
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = 0;
        if (!line[0]) continue;
        char **more = realloc(lines, (*n + 1) * sizeof *lines);
        if (!more) break;
        lines = more;
        lines[(*n)++] = dup(line);
    }
    fclose(f);
    return lines;
}

static void free_lines(char **lines, size_t n) {
    for (size_t i = 0; i < n; ++i) free(lines[i]);
    free(lines);
}

static void release(fmu *c) {
    if (c->sim) trainsim_free(c->sim);
    c->sim = NULL;
    free_lines(c->inputs, c->n_inputs);
    free_lines(c->params, c->n_params);
    free(c->input_value);
    free(c->param_value);
    free(c->theta);
    free(c->omega);
    for (size_t i = 0; i < c->n_saved; ++i) free(c->saved[i].inputs);
    free(c->saved);
    c->inputs = c->params = NULL;
    c->input_value = c->param_value = c->theta = c->omega = NULL;
    c->saved = NULL;
    c->n_inputs = c->n_params = c->n_saved = c->n_nodes = 0;
}

/* Read the deck and the variable lists from the resources (instantiate, reset). */
static int load(fmu *c) {
    char path[4400];
    size_t i;
    c->sim = trainsim_new();
    if (!c->sim) return 0;
    snprintf(path, sizeof path, "%s/deck.nml", c->dir);
    if (trainsim_read_file(c->sim, path) || trainsim_count(c->sim, TRAINSIM_NODES, &c->n_nodes)) {
        failed(c, "reading the FMU's deck");
        return 0;
    }
    c->inputs = read_lines(c->dir, "inputs.txt", &c->n_inputs);
    c->params = read_lines(c->dir, "parameters.txt", &c->n_params);
    c->input_value = calloc(c->n_inputs + 1, sizeof *c->input_value);
    c->param_value = calloc(c->n_params + 1, sizeof *c->param_value);
    c->theta = calloc(c->n_nodes + 1, sizeof *c->theta);
    c->omega = calloc(c->n_nodes + 1, sizeof *c->omega);
    if (!c->input_value || !c->param_value || !c->theta || !c->omega) return 0;
    for (i = 0; i < c->n_params; ++i) { /* "PATH<TAB>VALUE": the path kept, the value parsed */
        char *tab = strchr(c->params[i], '\t');
        if (tab) {
            *tab = 0;
            c->param_value[i] = strtod(tab + 1, NULL);
        }
    }
    c->time = 0;
    c->started = c->terminated = 0;
    return 1;
}

/* The session started (at the end of initialisation, or when an output is asked first):
 * every parameter value set, then the inputs' values. */
static fmi2Status start(fmu *c) {
    char list[65536] = "";
    size_t i, used = 0;
    if (c->started) return fmi2OK;
    for (i = 0; i < c->n_params; ++i)
        if (trainsim_set_real(c->sim, c->params[i], c->param_value[i])) return failed(c, "setting a parameter");
    for (i = 0; i < c->n_inputs; ++i) used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", i ? "," : "", c->inputs[i]);
    if (trainsim_session_start(c->sim, list)) return failed(c, "starting the run");
    c->started = 1;
    for (i = 0; i < c->n_inputs; ++i)
        if (c->input_value[i] != 0 && trainsim_session_set_torque(c->sim, c->inputs[i], c->input_value[i]))
            return failed(c, "setting an input");
    return fmi2OK;
}

FMI2_EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
FMI2_EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                                          const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
    (void)guid, (void)visible, (void)logging;
    fmu *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    c->name = dup(name ? name : "trainsim");
    if (cb) {
        c->logger = cb->logger;
        c->env = cb->componentEnvironment;
    }
    if (type != fmi2CoSimulation) {
        say(c, fmi2Error, "logStatusError", "trainsim FMUs are for co-simulation only");
    } else if (!uri_to_dir(resources, c->dir, sizeof c->dir)) {
        say(c, fmi2Error, "logStatusError", "no resource location given");
    } else if (load(c)) {
        return c;
    }
    release(c);
    free(c->name);
    free(c);
    return NULL;
}

FMI2_EXPORT void fmi2FreeInstance(fmi2Component comp) {
    fmu *c = comp;
    if (!c) return;
    release(c);
    free(c->name);
    free(c);
}

FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    (void)c, (void)on, (void)n, (void)cat;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean tol_defined, fmi2Real tol, fmi2Real t0,
                                           fmi2Boolean stop_defined, fmi2Real t1) {
    fmu *c = comp;
    (void)tol_defined, (void)tol;   /* the deck's integrator and tolerances are the FMU's */
    if (c->started) {
        say(c, fmi2Error, "logStatusError", "setupExperiment after initialisation");
        return fmi2Error;
    }
    if (trainsim_set_real(c->sim, "run.t_start", t0)) return failed(c, "the start time");
    if (stop_defined && trainsim_set_real(c->sim, "run.t_end", t1)) return failed(c, "the stop time");
    c->time = t0;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) { return start(c); }
FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component comp) { ((fmu *)comp)->terminated = 1; return fmi2OK; }

FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component comp) {
    fmu *c = comp;
    release(c);
    return load(c) ? fmi2OK : fmi2Error;
}

FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    fmu *c = comp;
    double t;
    int have_state = 0;
    for (size_t i = 0; i < n; ++i) {
        fmi2ValueReference r = vr[i];
        if (r >= VR_PARAM && r - VR_PARAM < c->n_params) {
            value[i] = c->param_value[r - VR_PARAM];
        } else if (r >= VR_INPUT && r - VR_INPUT < c->n_inputs) {
            value[i] = c->input_value[r - VR_INPUT];
        } else if (r >= 1 && r <= 2 * c->n_nodes) {
            if (!have_state) {
                if (start(c) != fmi2OK) return fmi2Error;
                if (trainsim_session_state(c->sim, &t, c->theta, c->omega, c->n_nodes)) return failed(c, "the state");
                have_state = 1;
            }
            value[i] = (r % 2) ? c->theta[(r - 1) / 2] : c->omega[(r - 1) / 2];
        } else {
            say(c, fmi2Error, "logStatusError", "getReal: no variable has value reference %u", r);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t n,
                                   const fmi2Real value[]) {
    fmu *c = comp;
    for (size_t i = 0; i < n; ++i) {
        fmi2ValueReference r = vr[i];
        if (r >= VR_PARAM && r - VR_PARAM < c->n_params) {
            if (c->started) {
                say(c, fmi2Error, "logStatusError", "parameter %s: set before initialisation ends", c->params[r - VR_PARAM]);
                return fmi2Error;
            }
            c->param_value[r - VR_PARAM] = value[i];
        } else if (r >= VR_INPUT && r - VR_INPUT < c->n_inputs) {
            c->input_value[r - VR_INPUT] = value[i];
            if (c->started && trainsim_session_set_torque(c->sim, c->inputs[r - VR_INPUT], value[i]))
                return failed(c, "setting an input");
        } else {
            say(c, fmi2Error, "logStatusError", "setReal: value reference %u is not an input or a parameter", r);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real t, fmi2Real h, fmi2Boolean no_set_prior) {
    fmu *c = comp;
    (void)no_set_prior;
    if (start(c) != fmi2OK) return fmi2Error;
    if (fabs(t - c->time) > 1e-9 * fmax(fabs(h), 1e-12) + 1e-15 * fabs(t)) {
        say(c, fmi2Error, "logStatusError", "doStep from t = %.17g, but the FMU is at t = %.17g", t, c->time);
        return fmi2Error;
    }
    if (trainsim_session_advance(c->sim, t + h)) return failed(c, "doStep");
    c->time = t + h;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *state) {
    fmu *c = comp;
    int point = -1;
    if (start(c) != fmi2OK) return fmi2Error;
    if (trainsim_session_save(c->sim, &point)) return failed(c, "getFMUstate");
    saved_point *more = realloc(c->saved, (c->n_saved + 1) * sizeof *more);
    if (!more) return fmi2Error;
    c->saved = more;
    c->saved[c->n_saved].time = c->time;
    c->saved[c->n_saved].inputs = malloc((c->n_inputs + 1) * sizeof(double));
    if (!c->saved[c->n_saved].inputs) return fmi2Error;
    memcpy(c->saved[c->n_saved].inputs, c->input_value, c->n_inputs * sizeof(double));
    ++c->n_saved;
    *state = (fmi2FMUstate)(intptr_t)(point + 1);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate state) {
    fmu *c = comp;
    intptr_t point = (intptr_t)state - 1;
    if (point < 0 || (size_t)point >= c->n_saved) {
        say(c, fmi2Error, "logStatusError", "setFMUstate: not a state of this FMU");
        return fmi2Error;
    }
    if (trainsim_session_restore(c->sim, (int)point)) return failed(c, "setFMUstate");
    c->time = c->saved[point].time;
    memcpy(c->input_value, c->saved[point].inputs, c->n_inputs * sizeof(double));
    return fmi2OK;
}

/* The saved points stay with the instance until it is freed (a few hundred bytes a node). */
FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    (void)c;
    if (state) *state = NULL;
    return fmi2OK;
}

static fmi2Status unsupported(fmi2Component comp, const char *what) {
    say(comp, fmi2Error, "logStatusError", "%s is not supported by trainsim FMUs", what);
    return fmi2Error;
}

FMI2_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    (void)s, (void)n;
    return unsupported(c, "serializing the FMU state");
}
FMI2_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    (void)s, (void)b, (void)n;
    return unsupported(c, "serializing the FMU state");
}
FMI2_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) {
    (void)s, (void)b, (void)n;
    return unsupported(c, "serializing the FMU state");
}
FMI2_EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                                    const fmi2ValueReference z[], size_t nz, const fmi2Real dv[],
                                                    fmi2Real dz[]) {
    (void)u, (void)nu, (void)z, (void)nz, (void)dv, (void)dz;
    return unsupported(c, "getDirectionalDerivative");
}
FMI2_EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                                   const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)n, (void)order, (void)value;
    return unsupported(c, "input derivatives");
}
FMI2_EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                                    const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)n, (void)order, (void)value;
    return unsupported(c, "output derivatives");
}
FMI2_EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "cancelStep"); }
FMI2_EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status *v) {
    (void)k, (void)v;
    return unsupported(c, "getStatus");
}
FMI2_EXPORT fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind k, fmi2Real *v) {
    fmu *c = comp;
    if (k != fmi2LastSuccessfulTime) return unsupported(c, "getRealStatus of this kind");
    *v = c->time;
    return fmi2OK;
}
FMI2_EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer *v) {
    (void)k, (void)v;
    return unsupported(c, "getIntegerStatus");
}
FMI2_EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind k, fmi2Boolean *v) {
    fmu *c = comp;
    if (k != fmi2Terminated) return unsupported(c, "getBooleanStatus of this kind");
    *v = c->terminated;
    return fmi2OK;
}
FMI2_EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *v) {
    (void)k, (void)v;
    return unsupported(c, "getStringStatus");
}

/* No integer, boolean or string variables: an empty call is fine, any reference an error. */
#define NO_VARIABLES(NAME, TYPE, CONST)                                                         \
    FMI2_EXPORT fmi2Status NAME(fmi2Component c, const fmi2ValueReference vr[], size_t n, CONST TYPE v[]) { \
        (void)vr, (void)v;                                                                      \
        return n == 0 ? fmi2OK : unsupported(c, #NAME " (no variable of this type)");           \
    }
NO_VARIABLES(fmi2GetInteger, fmi2Integer, )
NO_VARIABLES(fmi2GetBoolean, fmi2Boolean, )
NO_VARIABLES(fmi2GetString, fmi2String, )
NO_VARIABLES(fmi2SetInteger, fmi2Integer, const)
NO_VARIABLES(fmi2SetBoolean, fmi2Boolean, const)
NO_VARIABLES(fmi2SetString, fmi2String, const)
