/*
 * The C ABI from C99: a tree of 10,000 lights shared by two threads (pthreads), a dump for the
 * Rust harness's pmf consistency check, cuts, every direct technique against a closed form,
 * the lower level with a host BSDF, VPL acceptance, and bad input for every function.
 *
 * Usage: test_abi DUMP_PATH
 */
#define _POSIX_C_SOURCE 200809L
#include "scenarios.h"
#include "visibility_cache.h"

#include <pthread.h>

/* A light of each kind written with C99 designated initializers builds, each member's kind
 * is the union's, and a bad field is named by its member and field. */
static void scenario_designated(void) {
    ml_light ls[7] = {
        {.point = {.kind = ML_LIGHT_KIND_POINT, .position = {0, 0, 2}, .intensity = {1, 1, 1}}},
        {.spot = {.kind = ML_LIGHT_KIND_SPOT,
                  .position = {1, 0, 2},
                  .axis = {0, 0, -1},
                  .intensity = {1, 2, 3},
                  .half_angle = 0.5f,
                  .falloff_start = 0.2f}},
        {.sphere = {.kind = ML_LIGHT_KIND_SPHERE,
                    .center = {2, 0, 2},
                    .radius = 0.1f,
                    .radiance = {1, 1, 1}}},
        {.disk = {.kind = ML_LIGHT_KIND_DISK,
                  .center = {3, 0, 2},
                  .normal = {0, 0, -1},
                  .radius = 0.1f,
                  .radiance = {1, 1, 1},
                  .two_sided = 1}},
        {.triangle = {.kind = ML_LIGHT_KIND_TRIANGLE,
                      .v0 = {4, 0, 2},
                      .v1 = {4.2f, 0, 2},
                      .v2 = {4, 0.2f, 2},
                      .radiance = {1, 1, 1}}},
        {.vpl = {.kind = ML_LIGHT_KIND_VPL,
                 .position = {5, 0, 2},
                 .normal = {0, 0, -1},
                 .intensity = {1, 1, 1}}},
        {.distant = {.kind = ML_LIGHT_KIND_DISTANT,
                     .direction = {0.2f, 0, 1},
                     .angular_radius = 0.01f,
                     .irradiance = {2, 2, 2}}},
    };
    ml_tree *tree = NULL;
    ml_tree_statistics st;
    ml_light_point p;
    uint32_t k;
    for (k = 0; k < 7; k++) CHECK(ls[k].kind == k);
    CHECK(ls[3].disk.kind == ML_LIGHT_KIND_DISK && ls[6].distant.kind == ML_LIGHT_KIND_DISTANT);
    OK(ml_tree_build(ls, 7, NULL, NULL, &tree));
    OK(ml_tree_stats(tree, &st));
    CHECK(st.lights == 7 && st.sampled_lights == 7);
    /* The spot's intensity on its axis, 2 units below it. */
    OK(ml_light_sample_point(tree, 1, v3(1, 0, 0), 0.5f, 0.5f, &p));
    CHECK(p.delta == 1 && fabsf(p.radiance.b - 3.0f / 4.0f) < 1e-6f);
    OK(ml_tree_free(tree));
    tree = NULL;
    /* Bad fields, named by the kind's member. */
    ls[2].sphere.radius = -1;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 7, NULL, NULL, &tree), ML_ERR_INVALID_ARGUMENT,
              "lights[2].sphere.radius must be positive (got -1)");
    ls[2].sphere.radius = 0.1f;
    ls[0] = (ml_light){.sphere = {.kind = ML_LIGHT_KIND_SPHERE, .center = {0, 0, 2}, .radius = -2}};
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 7, NULL, NULL, &tree), ML_ERR_INVALID_ARGUMENT,
              "lights[0].sphere.radius must be positive (got -2)");
    ls[0] = (ml_light){.point = {.kind = ML_LIGHT_KIND_POINT, .position = {0, 0, 2}}};
    ls[1].spot.axis = v3(0, 0, 0);
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 7, NULL, NULL, &tree), ML_ERR_INVALID_ARGUMENT,
              "lights[1].spot.axis has zero length");
    ls[1].spot.axis = v3(0, 0, -1);
    ls[4].triangle.v2.z = (float)NAN;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 7, NULL, NULL, &tree), ML_ERR_INVALID_ARGUMENT,
              "lights[4].triangle.v2 is NaN or infinite");
    ls[4].triangle.v2.z = 2;
    ls[5].vpl.intensity.g = -1;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 7, NULL, NULL, &tree), ML_ERR_INVALID_ARGUMENT,
              "lights[5].vpl.intensity is negative (got -1)");
    ls[5].vpl.intensity.g = 1;
    ls[6].distant.angular_radius = 2;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 7, NULL, NULL, &tree), ML_ERR_INVALID_ARGUMENT,
              "lights[6].distant.angular_radius must be in [0, pi/2] (got 2)");
    ls[6].distant.angular_radius = 0.01f;
    ls[6].distant.irradiance.r = (float)INFINITY;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 7, NULL, NULL, &tree), ML_ERR_INVALID_ARGUMENT,
              "lights[6].distant.irradiance is NaN or infinite");
    CHECK(tree == NULL);
}

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
    scenario_visibility_cache();
    bad_input_visibility_cache();
    scenario_parallel_build();
    scenario_bad_input(tree, n);
    scenario_designated();

    OK(ml_tree_free(tree));
    free(lights);
    print_coverage();
    printf("%s: %d failures\n", argv[0], g_failures);
    return g_failures == 0 ? 0 : 1;
}
