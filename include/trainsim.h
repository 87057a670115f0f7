/* trainsim.h: the C interface of trainsim (libtrainsim_c; docs/c-api.md).
 *
 *   trainsim_sim *sim = trainsim_new();
 *   if (trainsim_read_file(sim, "inputs/gregory_harris_munro.nml") ||
 *       trainsim_set_real(sim, "mesh.half_backlash", 0.004) ||
 *       trainsim_run(sim, TRAINSIM_RUN_SERIES | TRAINSIM_RUN_EVENTS, NULL)) {
 *       char msg[1024];
 *       trainsim_error_message(sim, msg, sizeof msg);   // file, line, group, key
 *       fprintf(stderr, "%s\n", msg);
 *   }
 *   double p2p;
 *   trainsim_metric(sim, "mesh.p2p_mean", &p2p);
 *   trainsim_free(sim);
 *
 * Every function that can fail returns 0 or an error code (TRAINSIM_ERR_*) and keeps the
 * message of the handle's last call. Nothing in the library stops the process. Results
 * are copied into buffers the caller owns: ask the size first (trainsim_count). Strings
 * are copied as snprintf does (at most size - 1 characters and a NUL). Indices are
 * 0-based. A handle is used by one thread at a time.
 */
#ifndef TRAINSIM_H
#define TRAINSIM_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Error codes (trainsim_error.f90; TRAINSIM_ERR_ARGUMENT is the C interface's own). */
enum {
    TRAINSIM_OK = 0,
    TRAINSIM_ERR_INPUT = 1,       /* bad deck, value or parameter path */
    TRAINSIM_ERR_IO = 2,          /* unreadable deck, unwritable history */
    TRAINSIM_ERR_NUMERIC = 3,     /* the run failed (blow-up, solver failure, event flood) */
    TRAINSIM_ERR_INTERNAL = 4,
    TRAINSIM_ERR_INTERRUPTED = 5, /* stopped by SIGINT/SIGTERM (handlers are the caller's) */
    TRAINSIM_ERR_ARGUMENT = 6     /* NULL or freed handle, index out of range, buffer too small, no run yet */
};

/* trainsim_run flags */
enum {
    TRAINSIM_RUN_SERIES = 1,  /* keep the sampled history (trainsim_series) */
    TRAINSIM_RUN_EVENTS = 2   /* keep the event table (trainsim_events) */
};

/* What trainsim_count and trainsim_name list */
enum {
    TRAINSIM_METRICS = 1,          /* "mesh.p2p_mean", "n1.speed_max", "run.steps", ... (after a run) */
    TRAINSIM_METRIC_UNITS = 2,     /* the unit of each metric */
    TRAINSIM_SERIES = 3,           /* series columns: "time", "nodes/omega/n1", ... (run with TRAINSIM_RUN_SERIES) */
    TRAINSIM_SERIES_UNITS = 4,     /* the unit of each series column */
    TRAINSIM_EVENT_COLUMNS = 5,    /* "time", "element", "kind", ... */
    TRAINSIM_ELEMENTS = 6,         /* element ids, deck order (builds the model) */
    TRAINSIM_NODES = 7,            /* node ids, deck order (builds the model) */
    TRAINSIM_SWEEP_PARAMETERS = 8, /* the deck's &sweep parameters */
    TRAINSIM_SAMPLES = 9,          /* count only: rows of the series */
    TRAINSIM_EVENTS = 10,          /* count only: rows of the event table */
    TRAINSIM_SWEEP_RUNS = 11,      /* count only: runs of the deck's &sweep groups */
    TRAINSIM_EVENT_KINDS = 12      /* names of event kinds 1.. (the "kind" column) */
};

typedef struct trainsim_sim trainsim_sim;

/* Handles */
trainsim_sim *trainsim_new(void);            /* NULL only when out of memory */
void trainsim_free(trainsim_sim *sim);        /* NULL is ignored */
const char *trainsim_library_version(void);   /* "0.1.0 (git ...)" */

/* Errors: the code and message of the handle's last call ("" after a success).
 * trainsim_error_message returns the message's full length; NULL sim: the message of
 * the last call that was given no valid handle. */
int trainsim_error_code(const trainsim_sim *sim);
size_t trainsim_error_message(const trainsim_sim *sim, char *buf, size_t size);

/* Deck and parameters. A deck's &sweep groups are kept apart: the deck's own values
 * are run; trainsim_sweep_values gives the sweep's runs. name: the file name in
 * messages (NULL: "<text>"). */
int trainsim_read_file(trainsim_sim *sim, const char *path);
int trainsim_read_text(trainsim_sim *sim, const char *text, const char *name);
/* GROUP.KEY as trainsim's --set: value in deck syntax ("0.002", "'cvode-bdf'") */
int trainsim_set(trainsim_sim *sim, const char *path, const char *value);
int trainsim_set_real(trainsim_sim *sim, const char *path, double value);
int trainsim_clear(trainsim_sim *sim);        /* forget every set */

/* Build (when the deck or a parameter changed) and run; output: an HDF5 history (NULL: none). */
int trainsim_run(trainsim_sim *sim, int flags, const char *output);

/* Sizes and names */
int trainsim_count(trainsim_sim *sim, int what, size_t *n);
int trainsim_name(trainsim_sim *sim, int what, size_t i, char *buf, size_t size, size_t *length);

/* Values, copied into the caller's buffer of n doubles */
int trainsim_metric(trainsim_sim *sim, const char *name, double *value);
int trainsim_metrics(trainsim_sim *sim, double *values, size_t n);       /* TRAINSIM_METRICS order */
int trainsim_series(trainsim_sim *sim, double *values, size_t n);        /* row-major samples x columns */
int trainsim_events(trainsim_sim *sim, double *values, size_t n);        /* row-major events x columns */
int trainsim_sweep_values(trainsim_sim *sim, double *values, size_t n);  /* row-major runs x parameters */

/* Sessions: a run the caller advances (the base of co-simulation; docs/c-api.md). A handle
 * holds at most one session, of its model as built now; the same integrator, event
 * location and mode updates as trainsim_run, and advancing through a run's output times
 * gives its samples bit for bit. save/restore: a point (time, state, modes) to go back
 * to; both start the integrator afresh there, so a restored session continues exactly
 * as it did after the save. Metrics and events are not rolled back. Inputs, named at the
 * start ("n4,n1.speed,m.voltage"): NODE (or NODE.tau) an external torque (0 at first)
 * beside the deck's loads; NODE.speed the node's prescribed speed, NODE.voltage a DC
 * motor's supply voltage, each replacing the deck's and held at its value at t_start. A
 * value set acts from the session's time on (held: a step there); a speed keeps the
 * node's angle continuous. A positioning sequence's progress is saved and restored. */
int trainsim_session_start(trainsim_sim *sim, const char *inputs); /* "n4,n1.speed,m.voltage" */
int trainsim_session_set_input(trainsim_sim *sim, const char *name, double value);
int trainsim_session_set_torque(trainsim_sim *sim, const char *node, double value); /* "NODE.tau" */
int trainsim_session_advance(trainsim_sim *sim, double t);  /* t: up to run.t_end */
int trainsim_session_state(trainsim_sim *sim, double *t, double *theta, double *omega,
                           size_t n);                       /* n: TRAINSIM_NODES count */
int trainsim_session_elements(trainsim_sim *sim, double *disp, double *force, double *contact,
                              size_t n);                    /* n: TRAINSIM_ELEMENTS count */
int trainsim_session_save(trainsim_sim *sim, int *point);
int trainsim_session_restore(trainsim_sim *sim, int point);

#ifdef __cplusplus
}
#endif

#endif /* TRAINSIM_H */
