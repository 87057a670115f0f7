/* trainsim_fmi3.c: the FMI 3.0 co-simulation functions (docs/fmu.md) over fmu_core.c,
 * which holds the deck, the variables, the session that doStep advances and the saved
 * points (value references in fmu_core.h; 0 is time, the independent variable). Every
 * function of the standard is exported; those of model exchange, scheduled execution,
 * clocks and the types trainsim FMUs have no variables of answer fmi3Error (or fmi3OK for
 * an empty call). */
#include <stdlib.h>
#include <string.h>

#include "fmi3_abi.h"
#include "fmu_core.h"

typedef struct {
    fmu_core *core;
    fmi3LogMessageCallback log;
    fmi3InstanceEnvironment env;
} fmu3;

#define CORE(inst) (((fmu3 *)(inst))->core)

static void log_fmi3(void *ctx, int status, const char *category, const char *message) {
    fmu3 *c = ctx;
    if (c->log) c->log(c->env, (fmi3Status)status, category, message);
}

static fmi3Status unsupported(fmi3Instance inst, const char *what) {
    fmu3 *c = inst;
    if (c && c->core) fmu_say(c->core, FMU_ERROR, "%s is not supported by trainsim FMUs", what);
    return fmi3Error;
}

FMI3_EXPORT const char *fmi3GetVersion(void) { return "3.0"; }

FMI3_EXPORT fmi3Status fmi3SetDebugLogging(fmi3Instance inst, fmi3Boolean on, size_t n, const fmi3String cat[]) {
    (void)inst, (void)on, (void)n, (void)cat;
    return fmi3OK;
}

FMI3_EXPORT fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String resources,
                                                     fmi3Boolean visible, fmi3Boolean logging, fmi3Boolean event_mode,
                                                     fmi3Boolean early_return, const fmi3ValueReference required[],
                                                     size_t n_required, fmi3InstanceEnvironment env,
                                                     fmi3LogMessageCallback log,
                                                     fmi3IntermediateUpdateCallback update) {
    (void)name, (void)token, (void)visible, (void)logging, (void)early_return, (void)required, (void)n_required;
    (void)update;
    fmu3 *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    c->log = log;
    c->env = env;
    if (event_mode) {
        log_fmi3(c, fmi3Error, "logStatusError", "trainsim FMUs have no event mode (hasEventMode = false)");
    } else if ((c->core = fmu_new(resources, log_fmi3, c))) {
        return c;
    }
    free(c);
    return NULL;
}

FMI3_EXPORT fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String resources,
                                                      fmi3Boolean visible, fmi3Boolean logging,
                                                      fmi3InstanceEnvironment env, fmi3LogMessageCallback log) {
    (void)name, (void)token, (void)resources, (void)visible, (void)logging;
    if (log) log(env, fmi3Error, "logStatusError", "trainsim FMUs are for co-simulation only");
    return NULL;
}

FMI3_EXPORT fmi3Instance fmi3InstantiateScheduledExecution(fmi3String name, fmi3String token, fmi3String resources,
                                                           fmi3Boolean visible, fmi3Boolean logging,
                                                           fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
                                                           fmi3ClockUpdateCallback clock, fmi3LockPreemptionCallback lock,
                                                           fmi3UnlockPreemptionCallback unlock) {
    (void)name, (void)token, (void)resources, (void)visible, (void)logging, (void)clock, (void)lock, (void)unlock;
    if (log) log(env, fmi3Error, "logStatusError", "trainsim FMUs are for co-simulation only");
    return NULL;
}

FMI3_EXPORT void fmi3FreeInstance(fmi3Instance inst) {
    fmu3 *c = inst;
    if (!c) return;
    fmu_free(c->core);
    free(c);
}

FMI3_EXPORT fmi3Status fmi3EnterInitializationMode(fmi3Instance inst, fmi3Boolean tol_defined, fmi3Float64 tol,
                                                   fmi3Float64 t0, fmi3Boolean stop_defined, fmi3Float64 t1) {
    (void)tol_defined, (void)tol;   /* the deck's integrator and tolerances are the FMU's */
    return (fmi3Status)fmu_setup(CORE(inst), t0, stop_defined, t1);
}

FMI3_EXPORT fmi3Status fmi3ExitInitializationMode(fmi3Instance inst) { return (fmi3Status)fmu_start(CORE(inst)); }
FMI3_EXPORT fmi3Status fmi3EnterStepMode(fmi3Instance inst) { (void)inst; return fmi3OK; }
FMI3_EXPORT fmi3Status fmi3Terminate(fmi3Instance inst) { CORE(inst)->terminated = 1; return fmi3OK; }
FMI3_EXPORT fmi3Status fmi3Reset(fmi3Instance inst) { return (fmi3Status)fmu_reset(CORE(inst)); }

FMI3_EXPORT fmi3Status fmi3GetFloat64(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                      fmi3Float64 values[], size_t n) {
    if (n != nvr) return unsupported(inst, "arrays (nValues other than nValueReferences)");
    return (fmi3Status)fmu_get(CORE(inst), vr, nvr, values);
}

FMI3_EXPORT fmi3Status fmi3SetFloat64(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                      const fmi3Float64 values[], size_t n) {
    if (n != nvr) return unsupported(inst, "arrays (nValues other than nValueReferences)");
    return (fmi3Status)fmu_set(CORE(inst), vr, nvr, values);
}

FMI3_EXPORT fmi3Status fmi3DoStep(fmi3Instance inst, fmi3Float64 t, fmi3Float64 h, fmi3Boolean no_set_prior,
                                  fmi3Boolean *event_handling_needed, fmi3Boolean *terminate, fmi3Boolean *early_return,
                                  fmi3Float64 *last_successful_time) {
    (void)no_set_prior;
    fmi3Status status = (fmi3Status)fmu_step(CORE(inst), t, h);
    if (event_handling_needed) *event_handling_needed = false;
    if (terminate) *terminate = false;
    if (early_return) *early_return = false;
    if (last_successful_time) *last_successful_time = CORE(inst)->time;
    return status;
}

FMI3_EXPORT fmi3Status fmi3GetFMUState(fmi3Instance inst, fmi3FMUState *state) {
    return (fmi3Status)fmu_save(CORE(inst), state);
}

FMI3_EXPORT fmi3Status fmi3SetFMUState(fmi3Instance inst, fmi3FMUState state) {
    return (fmi3Status)fmu_restore(CORE(inst), state);
}

/* The saved points stay with the instance until it is freed (a few hundred bytes a node). */
FMI3_EXPORT fmi3Status fmi3FreeFMUState(fmi3Instance inst, fmi3FMUState *state) {
    (void)inst;
    if (state) *state = NULL;
    return fmi3OK;
}

/* Int32 and String parameters (deck values written as integers or texts). */
FMI3_EXPORT fmi3Status fmi3GetInt32(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 v[],
                                    size_t n) {
    if (n != nvr) return unsupported(inst, "arrays (nValues other than nValueReferences)");
    return (fmi3Status)fmu_get_int(CORE(inst), vr, nvr, v);
}
FMI3_EXPORT fmi3Status fmi3SetInt32(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 v[],
                                    size_t n) {
    if (n != nvr) return unsupported(inst, "arrays (nValues other than nValueReferences)");
    return (fmi3Status)fmu_set_int(CORE(inst), vr, nvr, v);
}
FMI3_EXPORT fmi3Status fmi3GetString(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, fmi3String v[],
                                     size_t n) {
    if (n != nvr) return unsupported(inst, "arrays (nValues other than nValueReferences)");
    return (fmi3Status)fmu_get_text(CORE(inst), vr, nvr, v);
}
FMI3_EXPORT fmi3Status fmi3SetString(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, const fmi3String v[],
                                     size_t n) {
    if (n != nvr) return unsupported(inst, "arrays (nValues other than nValueReferences)");
    return (fmi3Status)fmu_set_text(CORE(inst), vr, nvr, v);
}
/* Types without variables: an empty call is fine, a reference an error. */
#define NO_GET(NAME, T)                                                                                       \
    FMI3_EXPORT fmi3Status NAME(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, T v[], size_t n) { \
        (void)vr, (void)v, (void)n;                                                                           \
        return nvr == 0 ? fmi3OK : unsupported(inst, #NAME " (no variable of this type)");                    \
    }
#define NO_SET(NAME, T)                                                                                       \
    FMI3_EXPORT fmi3Status NAME(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, const T v[],    \
                                size_t n) {                                                                   \
        (void)vr, (void)v, (void)n;                                                                           \
        return nvr == 0 ? fmi3OK : unsupported(inst, #NAME " (no variable of this type)");                    \
    }
NO_GET(fmi3GetFloat32, fmi3Float32) NO_SET(fmi3SetFloat32, fmi3Float32)
NO_GET(fmi3GetInt8, fmi3Int8) NO_SET(fmi3SetInt8, fmi3Int8)
NO_GET(fmi3GetUInt8, fmi3UInt8) NO_SET(fmi3SetUInt8, fmi3UInt8)
NO_GET(fmi3GetInt16, fmi3Int16) NO_SET(fmi3SetInt16, fmi3Int16)
NO_GET(fmi3GetUInt16, fmi3UInt16) NO_SET(fmi3SetUInt16, fmi3UInt16)
NO_GET(fmi3GetUInt32, fmi3UInt32) NO_SET(fmi3SetUInt32, fmi3UInt32)
NO_GET(fmi3GetInt64, fmi3Int64) NO_SET(fmi3SetInt64, fmi3Int64)
NO_GET(fmi3GetUInt64, fmi3UInt64) NO_SET(fmi3SetUInt64, fmi3UInt64)
NO_GET(fmi3GetBoolean, fmi3Boolean) NO_SET(fmi3SetBoolean, fmi3Boolean)

FMI3_EXPORT fmi3Status fmi3GetBinary(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, size_t sizes[],
                                     fmi3Binary v[], size_t n) {
    (void)vr, (void)sizes, (void)v, (void)n;
    return nvr == 0 ? fmi3OK : unsupported(inst, "fmi3GetBinary (no variable of this type)");
}
FMI3_EXPORT fmi3Status fmi3SetBinary(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, const size_t sizes[],
                                     const fmi3Binary v[], size_t n) {
    (void)vr, (void)sizes, (void)v, (void)n;
    return nvr == 0 ? fmi3OK : unsupported(inst, "fmi3SetBinary (no variable of this type)");
}
FMI3_EXPORT fmi3Status fmi3GetClock(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, fmi3Clock v[]) {
    (void)vr, (void)v;
    return nvr == 0 ? fmi3OK : unsupported(inst, "clocks");
}
FMI3_EXPORT fmi3Status fmi3SetClock(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock v[]) {
    (void)vr, (void)v;
    return nvr == 0 ? fmi3OK : unsupported(inst, "clocks");
}

FMI3_EXPORT fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance inst, fmi3ValueReference vr, size_t *n) {
    (void)inst, (void)vr;
    *n = 0;   /* not given: every output depends on every input and the state */
    return fmi3OK;
}
FMI3_EXPORT fmi3Status fmi3GetVariableDependencies(fmi3Instance inst, fmi3ValueReference dependent, size_t ei[],
                                                   fmi3ValueReference independents[], size_t ej[],
                                                   fmi3DependencyKind kinds[], size_t n) {
    (void)dependent, (void)ei, (void)independents, (void)ej, (void)kinds;
    return n == 0 ? fmi3OK : unsupported(inst, "variable dependencies");
}

FMI3_EXPORT fmi3Status fmi3SerializedFMUStateSize(fmi3Instance inst, fmi3FMUState s, size_t *n) {
    (void)s, (void)n;
    return unsupported(inst, "serializing the FMU state");
}
FMI3_EXPORT fmi3Status fmi3SerializeFMUState(fmi3Instance inst, fmi3FMUState s, fmi3Byte b[], size_t n) {
    (void)s, (void)b, (void)n;
    return unsupported(inst, "serializing the FMU state");
}
FMI3_EXPORT fmi3Status fmi3DeserializeFMUState(fmi3Instance inst, const fmi3Byte b[], size_t n, fmi3FMUState *s) {
    (void)s, (void)b, (void)n;
    return unsupported(inst, "serializing the FMU state");
}

#define NO_DERIVATIVE(NAME)                                                                                   \
    FMI3_EXPORT fmi3Status NAME(fmi3Instance inst, const fmi3ValueReference u[], size_t nu,                   \
                                const fmi3ValueReference k[], size_t nk, const fmi3Float64 seed[], size_t ns,  \
                                fmi3Float64 sens[], size_t nsens) {                                           \
        (void)u, (void)nu, (void)k, (void)nk, (void)seed, (void)ns, (void)sens, (void)nsens;                  \
        return unsupported(inst, #NAME);                                                                      \
    }
NO_DERIVATIVE(fmi3GetDirectionalDerivative)
NO_DERIVATIVE(fmi3GetAdjointDerivative)

#define NOT_HERE(NAME)                                                                                        \
    FMI3_EXPORT fmi3Status NAME(fmi3Instance inst) { return unsupported(inst, #NAME); }
NOT_HERE(fmi3EnterConfigurationMode)
NOT_HERE(fmi3ExitConfigurationMode)
NOT_HERE(fmi3EnterEventMode)
NOT_HERE(fmi3EvaluateDiscreteStates)
NOT_HERE(fmi3EnterContinuousTimeMode)

FMI3_EXPORT fmi3Status fmi3GetIntervalDecimal(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                              fmi3Float64 v[], fmi3IntervalQualifier q[]) {
    (void)vr, (void)nvr, (void)v, (void)q;
    return unsupported(inst, "clocks");
}
FMI3_EXPORT fmi3Status fmi3GetIntervalFraction(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                               fmi3UInt64 c[], fmi3UInt64 r[], fmi3IntervalQualifier q[]) {
    (void)vr, (void)nvr, (void)c, (void)r, (void)q;
    return unsupported(inst, "clocks");
}
FMI3_EXPORT fmi3Status fmi3GetShiftDecimal(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                           fmi3Float64 v[]) {
    (void)vr, (void)nvr, (void)v;
    return unsupported(inst, "clocks");
}
FMI3_EXPORT fmi3Status fmi3GetShiftFraction(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                            fmi3UInt64 c[], fmi3UInt64 r[]) {
    (void)vr, (void)nvr, (void)c, (void)r;
    return unsupported(inst, "clocks");
}
FMI3_EXPORT fmi3Status fmi3SetIntervalDecimal(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                              const fmi3Float64 v[]) {
    (void)vr, (void)nvr, (void)v;
    return unsupported(inst, "clocks");
}
FMI3_EXPORT fmi3Status fmi3SetIntervalFraction(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                               const fmi3UInt64 c[], const fmi3UInt64 r[]) {
    (void)vr, (void)nvr, (void)c, (void)r;
    return unsupported(inst, "clocks");
}
FMI3_EXPORT fmi3Status fmi3SetShiftDecimal(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                           const fmi3Float64 v[]) {
    (void)vr, (void)nvr, (void)v;
    return unsupported(inst, "clocks");
}
FMI3_EXPORT fmi3Status fmi3SetShiftFraction(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                            const fmi3UInt64 c[], const fmi3UInt64 r[]) {
    (void)vr, (void)nvr, (void)c, (void)r;
    return unsupported(inst, "clocks");
}
FMI3_EXPORT fmi3Status fmi3UpdateDiscreteStates(fmi3Instance inst, fmi3Boolean *update, fmi3Boolean *terminate,
                                                fmi3Boolean *nominals, fmi3Boolean *values, fmi3Boolean *next_defined,
                                                fmi3Float64 *next) {
    (void)update, (void)terminate, (void)nominals, (void)values, (void)next_defined, (void)next;
    return unsupported(inst, "fmi3UpdateDiscreteStates");
}
FMI3_EXPORT fmi3Status fmi3CompletedIntegratorStep(fmi3Instance inst, fmi3Boolean no_set, fmi3Boolean *enter_event,
                                                   fmi3Boolean *terminate) {
    (void)no_set, (void)enter_event, (void)terminate;
    return unsupported(inst, "model exchange");
}
FMI3_EXPORT fmi3Status fmi3SetTime(fmi3Instance inst, fmi3Float64 t) { (void)t; return unsupported(inst, "model exchange"); }

#define NO_ME_ARRAY(NAME, CONST)                                                                              \
    FMI3_EXPORT fmi3Status NAME(fmi3Instance inst, CONST fmi3Float64 v[], size_t n) {                         \
        (void)v, (void)n;                                                                                     \
        return unsupported(inst, "model exchange");                                                           \
    }
NO_ME_ARRAY(fmi3SetContinuousStates, const)
NO_ME_ARRAY(fmi3GetContinuousStateDerivatives, )
NO_ME_ARRAY(fmi3GetEventIndicators, )
NO_ME_ARRAY(fmi3GetContinuousStates, )
NO_ME_ARRAY(fmi3GetNominalsOfContinuousStates, )

FMI3_EXPORT fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance inst, size_t *n) {
    (void)n;
    return unsupported(inst, "model exchange");
}
FMI3_EXPORT fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance inst, size_t *n) {
    (void)n;
    return unsupported(inst, "model exchange");
}
FMI3_EXPORT fmi3Status fmi3GetOutputDerivatives(fmi3Instance inst, const fmi3ValueReference vr[], size_t nvr,
                                                const fmi3Int32 orders[], fmi3Float64 v[], size_t n) {
    (void)vr, (void)nvr, (void)orders, (void)v, (void)n;
    return unsupported(inst, "output derivatives");
}
FMI3_EXPORT fmi3Status fmi3ActivateModelPartition(fmi3Instance inst, fmi3ValueReference clock, fmi3Float64 t) {
    (void)clock, (void)t;
    return unsupported(inst, "scheduled execution");
}
