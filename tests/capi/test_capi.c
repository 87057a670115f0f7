/* The C interface from C (include/trainsim.h): a deck read from a file and from text,
 * a parameter set by its deck path, a run, a metric by name and the series; errors as
 * codes with trainsim's messages (file and line); misuse returns a code, never aborts.
 *
 * Checks with a reason outside the code: the GHM rig's prescribed speed of n1 is
 * 2 pi f / 32 after mesh.mesh_frequency = 485 (docs/sweeps.md: 95.22953 rad/s); the
 * series' node n1 speed column holds it at every sample (a held node); the series time
 * column is the uniform grid t_start + k dt_out (output-format.md); the metric
 * run.steps equals (t_end - t_start) / dt for RK4 at a fixed step. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trainsim.h"

static int failures = 0;

#define CHECK(cond, ...)                                   \
    do {                                                   \
        if (!(cond)) {                                     \
            ++failures;                                    \
            fprintf(stderr, "FAIL %s:%d: ", __FILE__, __LINE__); \
            fprintf(stderr, __VA_ARGS__);                  \
            fputc('\n', stderr);                           \
        }                                                  \
    } while (0)

static void print_error(trainsim_sim *sim) {
    char msg[2048];
    trainsim_error_message(sim, msg, sizeof msg);
    fprintf(stderr, "  trainsim: %s\n", msg);
}

static long index_of(trainsim_sim *sim, int what, const char *name) {
    size_t n = 0;
    char buf[256];
    trainsim_count(sim, what, &n);
    for (size_t i = 0; i < n; ++i) {
        trainsim_name(sim, what, i, buf, sizeof buf, NULL);
        if (strcmp(buf, name) == 0) return (long)i;
    }
    return -1;
}

static void test_deck_set_run_metric_series(const char *deck) {
    trainsim_sim *sim = trainsim_new();
    int rc = trainsim_read_file(sim, deck);
    CHECK(rc == TRAINSIM_OK, "read %s: code %d", deck, rc);
    if (rc) { print_error(sim); trainsim_free(sim); return; }
    /* shorter run: 0.005 s at dt 8e-6; a later set of one path wins */
    CHECK(trainsim_set(sim, "run.t_end", "0.001") == 0, "set run.t_end");
    CHECK(trainsim_set(sim, "run.t_end", "0.005") == 0, "set run.t_end again");
    CHECK(trainsim_set_real(sim, "mesh.mesh_frequency", 485.0) == 0, "set mesh.mesh_frequency");
    rc = trainsim_run(sim, TRAINSIM_RUN_SERIES | TRAINSIM_RUN_EVENTS, NULL);
    CHECK(rc == 0, "run: code %d", rc);
    if (rc) { print_error(sim); trainsim_free(sim); return; }

    double steps = 0, p2p = -1;
    CHECK(trainsim_metric(sim, "run.steps", &steps) == 0, "metric run.steps");
    CHECK(steps == 625.0, "run.steps = %g, (0.005 - 0) / 8e-6 = 625 expected", steps);
    CHECK(trainsim_metric(sim, "mesh.p2p_range", &p2p) == 0 && p2p > 0, "mesh.p2p_range = %g > 0", p2p);

    size_t nm = 0;
    trainsim_count(sim, TRAINSIM_METRICS, &nm);
    double *all = malloc(nm * sizeof *all);
    CHECK(trainsim_metrics(sim, all, nm) == 0, "all metrics");
    long k = index_of(sim, TRAINSIM_METRICS, "mesh.p2p_range");
    CHECK(k >= 0 && all[k] == p2p, "the metrics table holds mesh.p2p_range = %g", p2p);
    CHECK(trainsim_metrics(sim, all, nm - 1) == TRAINSIM_ERR_ARGUMENT, "a buffer one short is refused");
    free(all);

    size_t ncol = 0, nrow = 0;
    CHECK(trainsim_count(sim, TRAINSIM_SERIES, &ncol) == 0 && ncol > 0, "series columns");
    CHECK(trainsim_count(sim, TRAINSIM_SAMPLES, &nrow) == 0, "series rows");
    CHECK(nrow == 626, "%zu samples, 626 expected (t = 0, 8e-6, ..., 0.005)", nrow);
    double *series = malloc(ncol * nrow * sizeof *series);
    CHECK(trainsim_series(sim, series, ncol * nrow) == 0, "series values");
    long it = index_of(sim, TRAINSIM_SERIES, "time");
    long iw = index_of(sim, TRAINSIM_SERIES, "nodes/omega/n1");
    CHECK(it == 0 && iw > 0, "columns time (%ld) and nodes/omega/n1 (%ld)", it, iw);
    char unit[32];
    trainsim_name(sim, TRAINSIM_SERIES_UNITS, (size_t)iw, unit, sizeof unit, NULL);
    CHECK(strcmp(unit, "rad/s") == 0, "unit of nodes/omega/n1 is '%s'", unit);
    const double w = 2.0 * M_PI * 485.0 / 32.0;
    double worst_t = 0, worst_w = 0;
    for (size_t r = 0; r < nrow; ++r) {
        worst_t = fmax(worst_t, fabs(series[r * ncol + it] - 8e-6 * (double)r));
        worst_w = fmax(worst_w, fabs(series[r * ncol + iw] - w));
    }
    CHECK(worst_t <= 1e-15, "time column off the grid k * 8e-6 by %g", worst_t);
    CHECK(worst_w <= 1e-12 * w, "held n1 speed off 2 pi 485 / 32 by %g rad/s", worst_w);
    free(series);
    trainsim_free(sim);
}

/* A session over the same run: advanced through the run's output times it gives the
 * run's last sample bit for bit; saved at t1 and restored, it reaches the same state at
 * t2 bit for bit; the held node keeps 2 pi 485 / 32; misuse and going back are codes. */
static void test_session(const char *deck) {
    trainsim_sim *sim = trainsim_new();
    size_t nn = 0, ncol = 0, nrow = 0;
    int point = -1;
    CHECK(trainsim_session_advance(sim, 1e-3) == TRAINSIM_ERR_ARGUMENT, "advance without a session");
    CHECK(trainsim_read_file(sim, deck) == 0, "read %s", deck);
    trainsim_set(sim, "run.t_end", "0.005");
    trainsim_set(sim, "run.output_interval", "2e-4");
    trainsim_set_real(sim, "mesh.mesh_frequency", 485.0);
    CHECK(trainsim_run(sim, TRAINSIM_RUN_SERIES, NULL) == 0, "run");
    trainsim_count(sim, TRAINSIM_SERIES, &ncol);
    trainsim_count(sim, TRAINSIM_SAMPLES, &nrow);
    trainsim_count(sim, TRAINSIM_NODES, &nn);
    double *series = malloc(ncol * nrow * sizeof *series);
    trainsim_series(sim, series, ncol * nrow);
    long iw = index_of(sim, TRAINSIM_SERIES, "nodes/omega/n4");
    long ia = index_of(sim, TRAINSIM_SERIES, "nodes/theta/n4");
    CHECK(trainsim_session_start(sim, "n4, nx") == TRAINSIM_ERR_INPUT, "an input on a node that does not exist");
    int rc = trainsim_session_start(sim, "n4");
    CHECK(rc == 0, "session start: code %d", rc);
    if (rc) { print_error(sim); free(series); trainsim_free(sim); return; }
    double t = 0, th[16], om[16], th2[16], om2[16];
    CHECK(nn == 4, "4 nodes (%zu)", nn);
    CHECK(trainsim_session_state(sim, &t, th, om, nn - 1) == TRAINSIM_ERR_ARGUMENT, "a short buffer is refused");
    const double w = 2.0 * M_PI * 485.0 / 32.0;
    double worst_w = 0;
    for (size_t r = 1; r < nrow; ++r) {
        rc = trainsim_session_advance(sim, series[r * ncol]);
        if (rc) { print_error(sim); break; }
        trainsim_session_state(sim, &t, th, om, nn);
        worst_w = fmax(worst_w, fabs(om[0] - w));
        if (r == 10) CHECK(trainsim_session_save(sim, &point) == 0 && point == 0, "save at sample 10");
    }
    CHECK(rc == 0, "advanced through the run's %zu output times", nrow - 1);
    CHECK(t == series[(nrow - 1) * ncol], "at the last output time (%g)", t);
    CHECK(ia > 0 && iw > 0 && th[3] == series[(nrow - 1) * ncol + ia] && om[3] == series[(nrow - 1) * ncol + iw],
          "n4's angle and speed equal the run's last sample bit for bit (angle %.17g vs %.17g)", th[3],
          series[(nrow - 1) * ncol + ia]);
    CHECK(worst_w <= 1e-12 * w, "held n1 speed off 2 pi 485 / 32 by %g rad/s", worst_w);
    CHECK(trainsim_session_restore(sim, point) == 0, "restore the point of sample 10");
    trainsim_session_state(sim, &t, th2, om2, nn);
    CHECK(fabs(t - series[10 * ncol]) <= 1e-15, "restored to t = %g", t);
    CHECK(trainsim_session_advance(sim, 1e-3) == TRAINSIM_ERR_INPUT, "advancing backwards is refused");
    CHECK(trainsim_session_restore(sim, 7) == TRAINSIM_ERR_ARGUMENT, "restoring a point never saved is refused");
    CHECK(trainsim_session_set_torque(sim, "n3", 1.0) == TRAINSIM_ERR_INPUT, "a torque on a node not an input");
    CHECK(trainsim_session_set_torque(sim, "n4", 0.0) == 0, "the input torque on n4 set to 0 (unchanged)");
    CHECK(trainsim_session_advance(sim, series[(nrow - 1) * ncol]) == 0, "advance again to the end");
    trainsim_session_state(sim, &t, th2, om2, nn);
    CHECK(memcmp(th, th2, nn * sizeof *th) == 0 && memcmp(om, om2, nn * sizeof *om) == 0,
          "the second pass from the saved point ends in the same state, bit for bit");
    /* a speed input: n1 (driven by the deck) held at the value set, its angle continuous */
    CHECK(trainsim_session_start(sim, "n1.speed,n4.tau") == 0, "a session with a speed and a torque input");
    CHECK(trainsim_session_start(sim, "n4.speed") == TRAINSIM_ERR_INPUT, "a speed input on a free node is refused");
    CHECK(trainsim_session_start(sim, "n1.speed") == 0, "again with n1.speed");
    CHECK(trainsim_session_advance(sim, 1e-3) == 0 && trainsim_session_set_input(sim, "n1.speed", 100.0) == 0 &&
              trainsim_session_set_input(sim, "n2.speed", 1.0) == TRAINSIM_ERR_INPUT &&
              trainsim_session_set_input(sim, NULL, 1.0) == TRAINSIM_ERR_ARGUMENT,
          "set n1.speed to 100 rad/s at 1 ms; n2.speed (not an input) and NULL refused");
    trainsim_session_state(sim, &t, th, om, nn);
    CHECK(trainsim_session_advance(sim, 2e-3) == 0, "advance to 2 ms");
    trainsim_session_state(sim, &t, th2, om2, nn);
    CHECK(om2[0] == 100.0 && fabs(th2[0] - (th[0] + 100.0 * 1e-3)) <= 1e-12 * fabs(th2[0]),
          "n1 turns at 100 rad/s from 1 ms on, its angle continuous (%.17g, %.17g)", om2[0], th2[0] - th[0]);
    free(series);
    trainsim_free(sim);
}

static void test_bad_deck_names_file_and_line(void) {
    trainsim_sim *sim = trainsim_new();
    const char *text = "&run t_end = 0.1, dt = 1e-5 /\n"
                       "&node id = 'a', type = 'inertia', inertia = -1.0 /\n";
    int rc = trainsim_read_text(sim, text, "bad.nml");
    if (rc == 0) rc = trainsim_run(sim, 0, NULL);
    CHECK(rc == TRAINSIM_ERR_INPUT, "bad inertia: code %d, %d expected", rc, TRAINSIM_ERR_INPUT);
    char msg[1024];
    size_t n = trainsim_error_message(sim, msg, sizeof msg);
    CHECK(n > 0 && strstr(msg, "bad.nml:2") != NULL && strstr(msg, "inertia") != NULL,
          "message names file, line and key: '%s'", msg);
    /* a message longer than the buffer is cut, NUL-terminated, its length returned */
    char small[8];
    size_t full = trainsim_error_message(sim, small, sizeof small);
    CHECK(full == n && strlen(small) == 7, "truncated copy: %zu of %zu", strlen(small), full);

    rc = trainsim_read_file(sim, "no/such/deck.nml");
    CHECK(rc == TRAINSIM_ERR_IO || rc == TRAINSIM_ERR_INPUT, "missing deck: code %d", rc);
    trainsim_error_message(sim, msg, sizeof msg);
    CHECK(strstr(msg, "no/such/deck.nml") != NULL, "message names the file: '%s'", msg);

    rc = trainsim_read_text(sim, "&run t_end = 0.1, dt = 1e-5 /\n&node id = 'a', type = 'inertia', inertia = 1 /\n", NULL);
    CHECK(rc == 0, "good deck after a bad one");
    rc = trainsim_set(sim, "nosuch.key", "1");
    CHECK(rc == TRAINSIM_ERR_INPUT, "unknown group: code %d", rc);
    double v;
    CHECK(trainsim_metric(sim, "run.steps", &v) == TRAINSIM_ERR_ARGUMENT, "a metric before a run");
    trainsim_free(sim);

    /* misuse: no abort */
    CHECK(trainsim_run(NULL, 0, NULL) == TRAINSIM_ERR_ARGUMENT, "NULL handle");
    trainsim_error_message(NULL, msg, sizeof msg);
    CHECK(strstr(msg, "NULL") != NULL, "NULL handle message: '%s'", msg);
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: test_capi DECK (inputs/gregory_harris_munro.nml)\n");
        return 2;
    }
    printf("libtrainsim_c %s\n", trainsim_library_version());
    test_deck_set_run_metric_series(argv[1]);
    test_bad_deck_names_file_and_line();
    test_session(argv[1]);
    if (failures) {
        fprintf(stderr, "%d check(s) failed\n", failures);
        return 1;
    }
    printf("test_capi: all checks passed\n");
    return 0;
}
