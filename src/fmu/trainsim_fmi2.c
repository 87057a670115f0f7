/* trainsim_fmi2.c: the FMI 2.0 co-simulation functions (docs/fmu.md) over fmu_core.c,
 * which holds the deck, the variables, the session that doStep advances and the saved
 * points (value references in fmu_core.h). */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_abi.h"
#include "fmu_core.h"

typedef struct {
    fmu_core *core;
    char *name;
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
} fmu2;

#define CORE(comp) (((fmu2 *)(comp))->core)

static void log_fmi2(void *ctx, int status, const char *category, const char *message) {
    fmu2 *c = ctx;
    if (c->logger) c->logger(c->env, c->name, (fmi2Status)status, category, "%s", message);
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
    out[n] = 0;
    return n > 0;
}

FMI2_EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
FMI2_EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                                          const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
    char dir[4096];
    (void)guid, (void)visible, (void)logging;
    fmu2 *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    c->name = malloc(strlen(name ? name : "trainsim") + 1);
    if (c->name) strcpy(c->name, name ? name : "trainsim");
    if (cb) {
        c->logger = cb->logger;
        c->env = cb->componentEnvironment;
    }
    if (type != fmi2CoSimulation) {
        log_fmi2(c, fmi2Error, "logStatusError", "trainsim FMUs are for co-simulation only");
    } else if (!uri_to_dir(resources, dir, sizeof dir)) {
        log_fmi2(c, fmi2Error, "logStatusError", "no resource location given");
    } else if ((c->core = fmu_new(dir, log_fmi2, c))) {
        return c;
    }
    free(c->name);
    free(c);
    return NULL;
}

FMI2_EXPORT void fmi2FreeInstance(fmi2Component comp) {
    fmu2 *c = comp;
    if (!c) return;
    fmu_free(c->core);
    free(c->name);
    free(c);
}

FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    (void)c, (void)on, (void)n, (void)cat;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean tol_defined, fmi2Real tol, fmi2Real t0,
                                           fmi2Boolean stop_defined, fmi2Real t1) {
    (void)tol_defined, (void)tol;   /* the deck's integrator and tolerances are the FMU's */
    return (fmi2Status)fmu_setup(CORE(comp), t0, stop_defined, t1);
}

FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) { return (fmi2Status)fmu_start(CORE(c)); }
FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component c) { CORE(c)->terminated = 1; return fmi2OK; }
FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component c) { return (fmi2Status)fmu_reset(CORE(c)); }

FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    return (fmi2Status)fmu_get(CORE(c), vr, n, value);
}

FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    return (fmi2Status)fmu_set(CORE(c), vr, n, value);
}

FMI2_EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_set_prior) {
    (void)no_set_prior;
    return (fmi2Status)fmu_step(CORE(c), t, h);
}

FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    return (fmi2Status)fmu_save(CORE(c), state);
}

FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    return (fmi2Status)fmu_restore(CORE(c), state);
}

/* The saved points stay with the instance until it is freed (a few hundred bytes a node). */
FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    (void)c;
    if (state) *state = NULL;
    return fmi2OK;
}

static fmi2Status unsupported(fmi2Component comp, const char *what) {
    fmu_say(CORE(comp), FMU_ERROR, "%s is not supported by trainsim FMUs", what);
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
FMI2_EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real *v) {
    if (k != fmi2LastSuccessfulTime) return unsupported(c, "getRealStatus of this kind");
    *v = CORE(c)->time;
    return fmi2OK;
}
FMI2_EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer *v) {
    (void)k, (void)v;
    return unsupported(c, "getIntegerStatus");
}
FMI2_EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v) {
    if (k != fmi2Terminated) return unsupported(c, "getBooleanStatus of this kind");
    *v = CORE(c)->terminated;
    return fmi2OK;
}
FMI2_EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *v) {
    (void)k, (void)v;
    return unsupported(c, "getStringStatus");
}

/* Integer and String parameters (deck values written as integers or texts). */
FMI2_EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    return (fmi2Status)fmu_get_int(CORE(c), vr, n, v);
}
FMI2_EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    return (fmi2Status)fmu_set_int(CORE(c), vr, n, v);
}
FMI2_EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    return (fmi2Status)fmu_get_text(CORE(c), vr, n, v);
}
FMI2_EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    return (fmi2Status)fmu_set_text(CORE(c), vr, n, v);
}

/* No boolean variables: an empty call is fine, any reference an error. */
#define NO_VARIABLES(NAME, TYPE, CONST)                                                         \
    FMI2_EXPORT fmi2Status NAME(fmi2Component c, const fmi2ValueReference vr[], size_t n, CONST TYPE v[]) { \
        (void)vr, (void)v;                                                                      \
        return n == 0 ? fmi2OK : unsupported(c, #NAME " (no variable of this type)");           \
    }
NO_VARIABLES(fmi2GetBoolean, fmi2Boolean, )
NO_VARIABLES(fmi2SetBoolean, fmi2Boolean, const)
