/* fmu_core.h: what the FMI 2.0 and 3.0 functions share (fmu_core.c): the deck and its
 * variables from the FMU's resources, parameters, inputs, the session that doStep
 * advances, saved points. Value references (the packer's rule, scripts/trainsim_fmu.py):
 *   0 time (FMI 3.0's independent variable); node k (0-based): angle 1 + 2k, speed 2 + 2k;
 *   input j: 1000000 + j; parameter p: 2000000 + p (Float64, Int32 or String, as
 *   parameters.txt says); element e (0-based): displacement
 *   3000000 + 3e, force (or torque) 3000001 + 3e, contact state 3000002 + 3e. */
#ifndef TRAINSIM_FMU_CORE_H
#define TRAINSIM_FMU_CORE_H

#include <stddef.h>

#include "trainsim.h"

/* statuses, ordered as FMI's (OK, Warning, Discard, Error, Fatal) */
enum { FMU_OK = 0, FMU_ERROR = 3 };

typedef void (*fmu_log)(void *ctx, int status, const char *category, const char *message);

typedef struct {
    double time;
    double *inputs;
} fmu_point;

typedef struct {
    trainsim_sim *sim;
    fmu_log log;
    void *log_ctx;
    char dir[4096];
    size_t n_nodes, n_elements, n_inputs, n_params, n_saved;
    char **inputs, **params;      /* input names (NODE.tau, NODE.speed, NODE.voltage); parameter paths */
    char *param_type;             /* 'r' Float64, 'i' Int32, 's' String */
    char **param_text;            /* a String parameter's value */
    int *input_set;               /* set by the importer (else the deck's value holds) */
    double *input_value, *param_value, *theta, *omega, *disp, *force, *contact;
    fmu_point *saved;
    double time;
    int started, terminated;
} fmu_core;

fmu_core *fmu_new(const char *resource_dir, fmu_log log, void *log_ctx);
void fmu_free(fmu_core *c);
int fmu_reset(fmu_core *c);
void fmu_say(fmu_core *c, int status, const char *fmt, ...);
int fmu_setup(fmu_core *c, double t0, int stop_defined, double t1);
int fmu_start(fmu_core *c);
int fmu_get(fmu_core *c, const unsigned int vr[], size_t n, double value[]);
int fmu_set(fmu_core *c, const unsigned int vr[], size_t n, const double value[]);
int fmu_get_int(fmu_core *c, const unsigned int vr[], size_t n, int value[]);
int fmu_set_int(fmu_core *c, const unsigned int vr[], size_t n, const int value[]);
int fmu_get_text(fmu_core *c, const unsigned int vr[], size_t n, const char *value[]);
int fmu_set_text(fmu_core *c, const unsigned int vr[], size_t n, const char *const value[]);
int fmu_step(fmu_core *c, double t, double h);
int fmu_save(fmu_core *c, void **state);
int fmu_restore(fmu_core *c, void *state);

#endif
