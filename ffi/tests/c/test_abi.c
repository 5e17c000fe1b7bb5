/*
 * The C ABI from C99: a tree of 10,000 lights shared by two threads (pthreads), a dump for the
 * Rust harness's pmf consistency check, cuts, every direct technique against a closed form,
 * the lower level with a host BSDF, VPL acceptance, and bad input for every function.
 *
 * Usage: test_abi DUMP_PATH
 */
#define _POSIX_C_SOURCE 200809L
#include "scenarios.h"

#include <pthread.h>

static void *thread_main(void *arg) {
    sample_job_run((sample_job *)arg);
    return NULL;
}

int main(int argc, char **argv) {
    const size_t n = 10000;
    ml_light *lights;
    ml_tree *tree;
    sample_job jobs[2];
    pthread_t threads[2];
    int i;
    if (argc != 2) {
        fprintf(stderr, "usage: %s DUMP_PATH\n", argv[0]);
        return 2;
    }
    lights = make_lights(n, 2024);
    tree = build_tree(lights, n);
    if (tree == NULL) return 1;

    /* Two threads sample the one tree at the same time. */
    for (i = 0; i < 2; i++) {
        jobs[i].tree = tree;
        jobs[i].seed = 1000 + (uint64_t)i;
        jobs[i].points = 1024;
        jobs[i].failures = 0;
        jobs[i].checksum = 0;
        CHECK(pthread_create(&threads[i], NULL, thread_main, &jobs[i]) == 0);
    }
    for (i = 0; i < 2; i++) {
        CHECK(pthread_join(threads[i], NULL) == 0);
        g_failures += jobs[i].failures;
    }
    CHECK(jobs[0].checksum > 0 && jobs[1].checksum > 0);

    dump_consistency(argv[1], tree, lights, n);
    scenario_tree(tree, n);
    scenario_cache(tree, lights, n);
    scenario_cut(tree, n);
    scenario_cut_infinite();
    scenario_narrow_sun();
    scenario_points(tree, lights, n);
    scenario_receiver();
    scenario_direct();
    scenario_lower_level();
    scenario_wavefront();
    scenario_infinite();
    scenario_environment_points();
    scenario_environment_batch();
    scenario_vpl();
    scenario_parallel_build();
    scenario_bad_input(tree, n);

    OK(ml_tree_free(tree));
    free(lights);
    print_coverage();
    printf("%s: %d failures\n", argv[0], g_failures);
    return g_failures == 0 ? 0 : 1;
}
