/* fmu_core.c: what the FMI 2.0 and 3.0 functions share (fmu_core.h; docs/fmu.md). The
 * deck travels in the FMU's resources (deck.nml) with the list of inputs (inputs.txt,
 * "NAME<TAB>START" a line, NAME as NODE.tau, NODE.speed or NODE.voltage) and of parameters
 * (parameters.txt, "PATH<TAB>TYPE<TAB>VALUE" a line, TYPE r, i or s), both written by
 * `trainsim fmu`. A step advances a session (trainsim_session_*): trainsim's own
 * integrator with its event location inside each communication step; an input is held
 * constant over a step and acts as a step at the communication point.
 * A saved point is a session point (a restored FMU continues bit for bit as it did after
 * the save) with the time and the inputs' values. */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_core.h"

enum { VR_INPUT = 1000000, VR_PARAM = 2000000, VR_ELEMENT = 3000000 };

void fmu_say(fmu_core *c, int status, const char *fmt, ...) {
    char msg[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (c && c->log) c->log(c->log_ctx, status, status >= FMU_ERROR ? "logStatusError" : "logAll", msg);
}

/* trainsim's message of the handle's last call, as an error. */
static int failed(fmu_core *c, const char *what) {
    char msg[4096];
    trainsim_error_message(c->sim, msg, sizeof msg);
    fmu_say(c, FMU_ERROR, "%s: %s", what, msg);
    return FMU_ERROR;
}

static char *dup(const char *s) {
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d) memcpy(d, s, n);
    return d;
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

static void release(fmu_core *c) {
    if (c->sim) trainsim_free(c->sim);
    c->sim = NULL;
    free_lines(c->inputs, c->n_inputs);
    free_lines(c->params, c->n_params);
    for (size_t i = 0; c->param_text && i < c->n_params; ++i) free(c->param_text[i]);
    free(c->param_text);
    free(c->param_type);
    free(c->input_set);
    free(c->input_value);
    free(c->param_value);
    free(c->theta);
    free(c->omega);
    free(c->disp);
    free(c->force);
    free(c->contact);
    for (size_t i = 0; i < c->n_saved; ++i) free(c->saved[i].inputs);
    free(c->saved);
    c->inputs = c->params = c->param_text = NULL;
    c->param_type = NULL;
    c->input_set = NULL;
    c->input_value = c->param_value = c->theta = c->omega = c->disp = c->force = c->contact = NULL;
    c->saved = NULL;
    c->n_inputs = c->n_params = c->n_saved = c->n_nodes = 0;
}

/* Read the deck and the variable lists from the resources (instantiate, reset). */
static int load(fmu_core *c) {
    char path[4400];
    size_t i;
    c->sim = trainsim_new();
    if (!c->sim) return 0;
    snprintf(path, sizeof path, "%s/deck.nml", c->dir);
    if (trainsim_read_file(c->sim, path) || trainsim_count(c->sim, TRAINSIM_NODES, &c->n_nodes) ||
        trainsim_count(c->sim, TRAINSIM_ELEMENTS, &c->n_elements)) {
        failed(c, "reading the FMU's deck");
        return 0;
    }
    c->inputs = read_lines(c->dir, "inputs.txt", &c->n_inputs);
    c->params = read_lines(c->dir, "parameters.txt", &c->n_params);
    c->input_value = calloc(c->n_inputs + 1, sizeof *c->input_value);
    c->param_value = calloc(c->n_params + 1, sizeof *c->param_value);
    c->param_type = calloc(c->n_params + 1, 1);
    c->param_text = calloc(c->n_params + 1, sizeof *c->param_text);
    c->input_set = calloc(c->n_inputs + 1, sizeof *c->input_set);
    c->theta = calloc(c->n_nodes + 1, sizeof *c->theta);
    c->omega = calloc(c->n_nodes + 1, sizeof *c->omega);
    c->disp = calloc(c->n_elements + 1, sizeof *c->disp);
    c->force = calloc(c->n_elements + 1, sizeof *c->force);
    c->contact = calloc(c->n_elements + 1, sizeof *c->contact);
    if (!c->input_value || !c->param_value || !c->param_type || !c->param_text || !c->input_set || !c->theta ||
        !c->omega || !c->disp || !c->force || !c->contact)
        return 0;
    for (i = 0; i < c->n_params; ++i) { /* "PATH<TAB>TYPE<TAB>VALUE": the path kept, the value parsed */
        char *tab = strchr(c->params[i], '\t');
        c->param_type[i] = 'r';
        if (!tab) continue;
        *tab = 0;
        if (tab[1] && tab[2] == '\t') {
            c->param_type[i] = tab[1];
            tab += 2;
        }
        if (c->param_type[i] == 's') {
            if (!(c->param_text[i] = dup(tab + 1))) return 0;
        } else {
            c->param_value[i] = strtod(tab + 1, NULL);
        }
    }
    for (i = 0; i < c->n_inputs; ++i) { /* "NAME<TAB>START" */
        char *tab = strchr(c->inputs[i], '\t');
        if (!tab) continue;
        *tab = 0;
        c->input_value[i] = strtod(tab + 1, NULL);
    }
    c->time = 0;
    c->started = c->terminated = 0;
    return 1;
}

/* Parameter i set in the deck (its value in deck syntax for an Int32 or a String). */
static int set_parameter(fmu_core *c, size_t i) {
    char text[4200];
    if (c->param_type[i] == 'i') {
        snprintf(text, sizeof text, "%d", (int)c->param_value[i]);
    } else if (c->param_type[i] == 's') {
        snprintf(text, sizeof text, "'%s'", c->param_text[i] ? c->param_text[i] : "");
    } else {
        return trainsim_set_real(c->sim, c->params[i], c->param_value[i]);
    }
    return trainsim_set(c->sim, c->params[i], text);
}

/* The session started (at the end of initialisation, or when an output is asked first):
 * every parameter value set, then the inputs the importer set. */
int fmu_start(fmu_core *c) {
    char list[65536] = "";
    size_t i, used = 0;
    if (c->started) return FMU_OK;
    for (i = 0; i < c->n_params; ++i)
        if (set_parameter(c, i)) return failed(c, "setting a parameter");
    for (i = 0; i < c->n_inputs; ++i) used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", i ? "," : "", c->inputs[i]);
    if (trainsim_session_start(c->sim, list)) return failed(c, "starting the run");
    c->started = 1;
    for (i = 0; i < c->n_inputs; ++i)
        if (c->input_set[i] && trainsim_session_set_input(c->sim, c->inputs[i], c->input_value[i]))
            return failed(c, "setting an input");
    return FMU_OK;
}

fmu_core *fmu_new(const char *dir, fmu_log log, void *log_ctx) {
    fmu_core *c = calloc(1, sizeof *c);
    size_t n;
    if (!c) return NULL;
    c->log = log;
    c->log_ctx = log_ctx;
    n = strlen(dir ? dir : "");
    if (n == 0 || n >= sizeof c->dir) {
        fmu_say(c, FMU_ERROR, "no resource location given");
        free(c);
        return NULL;
    }
    memcpy(c->dir, dir, n + 1);
    while (n > 1 && c->dir[n - 1] == '/') c->dir[--n] = 0;
    if (!load(c)) {
        release(c);
        free(c);
        return NULL;
    }
    return c;
}

void fmu_free(fmu_core *c) {
    if (!c) return;
    release(c);
    free(c);
}

int fmu_reset(fmu_core *c) {
    release(c);
    return load(c) ? FMU_OK : FMU_ERROR;
}

int fmu_setup(fmu_core *c, double t0, int stop_defined, double t1) {
    if (c->started) {
        fmu_say(c, FMU_ERROR, "the experiment is set up before initialisation ends");
        return FMU_ERROR;
    }
    if (trainsim_set_real(c->sim, "run.t_start", t0)) return failed(c, "the start time");
    if (stop_defined && trainsim_set_real(c->sim, "run.t_end", t1)) return failed(c, "the stop time");
    c->time = t0;
    return FMU_OK;
}

int fmu_get(fmu_core *c, const unsigned int vr[], size_t n, double value[]) {
    double t;
    int have_state = 0, have_elements = 0;
    for (size_t i = 0; i < n; ++i) {
        unsigned int r = vr[i];
        if (r >= VR_ELEMENT && r - VR_ELEMENT < 3 * c->n_elements) {
            if (!have_elements) {
                if (fmu_start(c) != FMU_OK) return FMU_ERROR;
                if (trainsim_session_elements(c->sim, c->disp, c->force, c->contact, c->n_elements))
                    return failed(c, "the elements' status");
                have_elements = 1;
            }
            unsigned int e = (r - VR_ELEMENT) / 3, k = (r - VR_ELEMENT) % 3;
            value[i] = k == 0 ? c->disp[e] : k == 1 ? c->force[e] : c->contact[e];
        } else if (r == 0) {
            value[i] = c->time;
        } else if (r >= VR_PARAM && r - VR_PARAM < c->n_params && c->param_type[r - VR_PARAM] == 'r') {
            value[i] = c->param_value[r - VR_PARAM];
        } else if (r >= VR_INPUT && r - VR_INPUT < c->n_inputs) {
            value[i] = c->input_value[r - VR_INPUT];
        } else if (r >= 1 && r <= 2 * c->n_nodes) {
            if (!have_state) {
                if (fmu_start(c) != FMU_OK) return FMU_ERROR;
                if (trainsim_session_state(c->sim, &t, c->theta, c->omega, c->n_nodes)) return failed(c, "the state");
                have_state = 1;
            }
            value[i] = (r % 2) ? c->theta[(r - 1) / 2] : c->omega[(r - 1) / 2];
        } else {
            fmu_say(c, FMU_ERROR, "get: no variable has value reference %u", r);
            return FMU_ERROR;
        }
    }
    return FMU_OK;
}

/* Whether parameter r may be set (before initialisation ends). */
static int settable(fmu_core *c, unsigned int r) {
    if (!c->started) return 1;
    fmu_say(c, FMU_ERROR, "parameter %s: set before initialisation ends", c->params[r - VR_PARAM]);
    return 0;
}

/* The index of parameter vr of type t ('i', 's'), else -1 (and an error said). */
static long parameter_of(fmu_core *c, unsigned int r, char t, const char *what) {
    if (r >= VR_PARAM && r - VR_PARAM < c->n_params && c->param_type[r - VR_PARAM] == t) return (long)(r - VR_PARAM);
    fmu_say(c, FMU_ERROR, "%s: value reference %u is not an %s parameter", what, r, t == 'i' ? "Int32" : "String");
    return -1;
}

int fmu_get_int(fmu_core *c, const unsigned int vr[], size_t n, int value[]) {
    for (size_t i = 0; i < n; ++i) {
        long p = parameter_of(c, vr[i], 'i', "get");
        if (p < 0) return FMU_ERROR;
        value[i] = (int)c->param_value[p];
    }
    return FMU_OK;
}

int fmu_set_int(fmu_core *c, const unsigned int vr[], size_t n, const int value[]) {
    for (size_t i = 0; i < n; ++i) {
        long p = parameter_of(c, vr[i], 'i', "set");
        if (p < 0 || !settable(c, vr[i])) return FMU_ERROR;
        c->param_value[p] = value[i];
    }
    return FMU_OK;
}

int fmu_get_text(fmu_core *c, const unsigned int vr[], size_t n, const char *value[]) {
    for (size_t i = 0; i < n; ++i) {
        long p = parameter_of(c, vr[i], 's', "get");
        if (p < 0) return FMU_ERROR;
        value[i] = c->param_text[p] ? c->param_text[p] : "";
    }
    return FMU_OK;
}

int fmu_set_text(fmu_core *c, const unsigned int vr[], size_t n, const char *const value[]) {
    for (size_t i = 0; i < n; ++i) {
        long p = parameter_of(c, vr[i], 's', "set");
        if (p < 0 || !settable(c, vr[i])) return FMU_ERROR;
        if (!value[i] || strchr(value[i], '\'') || strlen(value[i]) > 4000) {
            fmu_say(c, FMU_ERROR, "parameter %s: a text without a quote ' and under 4000 characters", c->params[p]);
            return FMU_ERROR;
        }
        char *copy = dup(value[i]);
        if (!copy) return FMU_ERROR;
        free(c->param_text[p]);
        c->param_text[p] = copy;
    }
    return FMU_OK;
}

int fmu_set(fmu_core *c, const unsigned int vr[], size_t n, const double value[]) {
    for (size_t i = 0; i < n; ++i) {
        unsigned int r = vr[i];
        if (r >= VR_PARAM && r - VR_PARAM < c->n_params && c->param_type[r - VR_PARAM] == 'r') {
            if (!settable(c, r)) return FMU_ERROR;
            c->param_value[r - VR_PARAM] = value[i];
        } else if (r >= VR_INPUT && r - VR_INPUT < c->n_inputs) {
            c->input_value[r - VR_INPUT] = value[i];
            c->input_set[r - VR_INPUT] = 1;
            if (c->started && trainsim_session_set_input(c->sim, c->inputs[r - VR_INPUT], value[i]))
                return failed(c, "setting an input");
        } else {
            fmu_say(c, FMU_ERROR, "set: value reference %u is not a Float64 input or parameter", r);
            return FMU_ERROR;
        }
    }
    return FMU_OK;
}

int fmu_step(fmu_core *c, double t, double h) {
    if (fmu_start(c) != FMU_OK) return FMU_ERROR;
    if (fabs(t - c->time) > 1e-9 * fmax(fabs(h), 1e-12) + 1e-15 * fabs(t)) {
        fmu_say(c, FMU_ERROR, "doStep from t = %.17g, but the FMU is at t = %.17g", t, c->time);
        return FMU_ERROR;
    }
    if (trainsim_session_advance(c->sim, t + h)) return failed(c, "doStep");
    c->time = t + h;
    return FMU_OK;
}

int fmu_save(fmu_core *c, void **state) {
    int point = -1;
    if (fmu_start(c) != FMU_OK) return FMU_ERROR;
    if (trainsim_session_save(c->sim, &point)) return failed(c, "getFMUState");
    fmu_point *more = realloc(c->saved, (c->n_saved + 1) * sizeof *more);
    if (!more) return FMU_ERROR;
    c->saved = more;
    c->saved[c->n_saved].time = c->time;
    c->saved[c->n_saved].inputs = malloc((c->n_inputs + 1) * sizeof(double));
    if (!c->saved[c->n_saved].inputs) return FMU_ERROR;
    memcpy(c->saved[c->n_saved].inputs, c->input_value, c->n_inputs * sizeof(double));
    ++c->n_saved;
    *state = (void *)(intptr_t)(point + 1);
    return FMU_OK;
}

int fmu_restore(fmu_core *c, void *state) {
    intptr_t point = (intptr_t)state - 1;
    if (point < 0 || (size_t)point >= c->n_saved) {
        fmu_say(c, FMU_ERROR, "setFMUState: not a state of this FMU");
        return FMU_ERROR;
    }
    if (trainsim_session_restore(c->sim, (int)point)) return failed(c, "setFMUState");
    c->time = c->saved[point].time;
    memcpy(c->input_value, c->saved[point].inputs, c->n_inputs * sizeof(double));
    return FMU_OK;
}
