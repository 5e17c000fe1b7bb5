/* Instruction counts of the wavefront batches against the single calls (callgrind; the
 * commands are in docs/measurements.md).
 * Usage: wave MODE TECHNIQUE; MODE 0 set-up only, 1 ml_direct_estimate per point,
 * 2 ml_direct_estimate_batch, 3 ml_light_sample_point per triple, 4 the batch. */
#include "scenarios.h"
int main(int argc, char **argv) {
    const size_t n = 10000, m = 1024, k = 4096;
    int mode = atoi(argv[1]);
    uint32_t t = (uint32_t)atoi(argv[2]);
    ml_light *lights = make_lights(n, 2024);
    ml_tree *tree = build_tree(lights, n);
    ml_shading_point *sps = (ml_shading_point *)malloc(m * sizeof *sps);
    double *out = (double *)calloc(m, sizeof *out), acc = 0;
    uint32_t *which = (uint32_t *)malloc(k * sizeof *which);
    ml_vec3 *xs = (ml_vec3 *)malloc(k * sizeof *xs);
    float *u0s = (float *)malloc(k * sizeof *u0s), *u1s = (float *)malloc(k * sizeof *u1s);
    ml_light_point *pts = (ml_light_point *)calloc(k, sizeof *pts);
    rng r, ru;
    ml_uniforms u = uniforms_of(&ru);
    size_t i;
    (void)argc;
    r.s = 5;
    ru.s = 9;
    for (i = 0; i < m; i++) sps[i] = make_sp(&r);
    for (i = 0; i < k; i++) {
        which[i] = (uint32_t)(rng_next(&r) % n);
        xs[i] = make_tl_point(&r).position;
        u0s[i] = rng_f32(&r);
        u1s[i] = rng_f32(&r);
    }
    if (mode == 1)
        for (i = 0; i < m; i++) OK(ml_direct_estimate(tree, &sps[i], t, NULL, NULL, &u, &out[i]));
    if (mode == 2) OK(ml_direct_estimate_batch(tree, sps, m, 1, t, NULL, NULL, &u, out));
    if (mode == 3)
        for (i = 0; i < k; i++) OK(ml_light_sample_point(tree, which[i], xs[i], u0s[i], u1s[i], &pts[i]));
    if (mode == 4) OK(ml_light_sample_point_batch(tree, which, xs, u0s, u1s, k, pts));
    for (i = 0; i < m; i++) acc += out[i];
    for (i = 0; i < k; i++) acc += pts[i].pdf;
    printf("%d %u %.17g\n", mode, (unsigned)t, acc);
    return g_failures;
}
