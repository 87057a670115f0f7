/* The C interface (docs/c-api.md): the GHM rig at two backlashes, the mesh's mean
 * peak-to-peak transmission error of each. Built by docs/examples/CMakeLists.txt
 * (target trainsim::trainsim_c); tests/consumer runs it against an install. */
#include <stdio.h>
#include <trainsim.h>

int main(int argc, char **argv) {
    const char *deck = argc > 1 ? argv[1] : "inputs/gregory_harris_munro.nml";
    double half_backlash[2] = {0.004, 0.006}, te[2];
    trainsim_sim *sim = trainsim_new();
    int rc = trainsim_read_file(sim, deck);
    for (int i = 0; i < 2 && rc == 0; ++i) {
        rc = trainsim_set_real(sim, "mesh.half_backlash", half_backlash[i]);
        if (rc == 0) rc = trainsim_run(sim, 0, NULL);                  /* metrics only */
        if (rc == 0) rc = trainsim_metric(sim, "mesh.p2p_mean", &te[i]);
    }
    if (rc != 0) {
        char msg[1024];
        trainsim_error_message(sim, msg, sizeof msg);
        fprintf(stderr, "c_api: %s\n", msg);
        trainsim_free(sim);
        return 2;
    }
    printf("trainsim %s: p2p TE %.6g in at half backlash 0.004, %.6g in at 0.006\n",
           trainsim_library_version(), te[0], te[1]);
    trainsim_free(sim);
    return te[0] != te[1] ? 0 : 1;
}
