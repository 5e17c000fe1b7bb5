/*
 * The visibility cache's scenario, shared by test_abi.c and test_abi.cpp (included after
 * scenarios.h): a tiny occluded scene rendered in passes with commits, through the one call
 * and the step loop, checked against the closed form after learning; and the bad input of
 * every ml_visibility_cache_* function and of the estimator's cache calls.
 */
#ifndef ML_TEST_VISIBILITY_CACHE_H
#define ML_TEST_VISIBILITY_CACHE_H

#include "scenarios.h"

#define VIS_LIGHTS 32

/* A wall at x = 0+: every shadow ray heading towards +x is blocked. Counts its calls. */
static int32_t vis_wall(void *user, ml_vec3 x, ml_vec3 d, float t) {
    (void)x;
    (void)t;
    ++*(long *)user;
    return d.x > 0 ? 1 : 0;
}

/* Half the lights on each side of the wall, above the plane z = 0; the exact radiance a
 * Lambert point of albedo rho at the origin (normal +z) reflects from the visible half. */
static double vis_scene(ml_light *ls, float rho) {
    rng r;
    int i;
    double e = 0;
    r.s = 4242;
    for (i = 0; i < VIS_LIGHTS; i++) {
        ml_vec3 p;
        float side = i % 2 == 0 ? -1.0f : 1.0f;
        memset(&ls[i], 0, sizeof ls[i]);
        p = v3(side * rng_range(&r, 1, 3), rng_range(&r, -1, 1), rng_range(&r, 1, 2));
        ls[i].point.kind = ML_LIGHT_KIND_POINT;
        ls[i].point.position = p;
        ls[i].point.intensity = grey(rng_range(&r, 0.5f, 2));
        if (p.x < 0) {
            double d2 = (double)p.x * p.x + (double)p.y * p.y + (double)p.z * p.z;
            e += ls[i].point.intensity.r * (p.z / sqrt(d2)) / d2;
        }
    }
    return rho / ML_PI * e;
}

static void scenario_visibility_cache(void) {
    ml_light ls[VIS_LIGHTS];
    const float rho = 0.7f;
    const double exact = vis_scene(ls, rho);
    ml_tree *tree = build_tree(ls, VIS_LIGHTS);
    ml_visibility_cache_options o;
    ml_visibility_cache *cache = NULL;
    ml_visibility_cache_counts c, before;
    ml_estimator *est = NULL;
    ml_visibility vis;
    ml_shading_point sp = direct_point(rho);
    running s;
    size_t bytes = 0;
    long calls = 0, k;
    int pass, i, j;
    rng r;
    ml_uniforms u = uniforms_of(&r);
    r.s = 99;
    memset(&vis, 0, sizeof vis);
    vis.occluded = vis_wall;
    vis.user_data = &calls;

    OK(ml_visibility_cache_options_default(0.5f, &o));
    CHECK(o.cell_size == 0.5f && o.cells == 4096 && o.slots == 256 && o.floor == 0.1f);
    o.cells = 64;
    o.slots = 64;
    OK(ml_visibility_cache_create(tree, &o, &cache));
    OK(ml_visibility_cache_bytes(cache, &bytes));
    CHECK(bytes == (size_t)64 * (64 * 17 + 1));
    OK(ml_estimator_create(tree, &est));
    OK(ml_estimator_set_visibility_cache(est, cache));

    /* Passes of the one call over a grid of points around the origin, committed after each. */
    for (pass = 0; pass < 3; pass++) {
        for (i = 0; i < 16; i++) {
            ml_shading_point p = sp;
            p.position = v3(-0.2f + 0.1f * (float)(i % 4), -0.2f + 0.1f * (float)(i / 4), 0);
            OK(ml_estimator_set_point(est, &p, ML_TECHNIQUE_DEFAULT, NULL));
            for (j = 0; j < 4; j++) {
                ml_rgb64 e = {-1, -1, -1};
                OK(ml_estimator_estimate(est, &vis, &u, &e));
                CHECK(estimate_ok(e));
            }
        }
        OK(ml_visibility_cache_commit(cache));
    }
    CHECK(calls > 0);
    OK(ml_visibility_cache_stats(cache, &c));
    CHECK(c.used > 0 && c.samples > 0 && c.visible > 0 && c.visible < c.samples);
    CHECK(c.samples <= (uint64_t)calls);

    /* A pass of the step loop, recording each light step's shadow ray. */
    before = c;
    OK(ml_estimator_set_point(est, &sp, ML_TECHNIQUE_DEFAULT, NULL));
    for (j = 0; j < 8; j++) {
        ml_step step;
        OK(ml_estimator_start(est));
        for (;;) {
            OK(ml_estimator_next(est, &u, &step));
            if (step.kind == ML_STEP_KIND_DONE) break;
            if (step.kind == ML_STEP_KIND_LIGHT) {
                CHECK(step.pmf > 0);
                OK(ml_estimator_record(est, step.point.direction.x > 0 ? 0u : 1u));
            }
        }
    }
    OK(ml_visibility_cache_commit(cache));
    OK(ml_visibility_cache_stats(cache, &c));
    CHECK(c.samples > before.samples && c.samples <= before.samples + 8 * 2);

    /* Sampling with what was learned, recording off: unbiased against the closed form. The
     * cache's handle is freed first: the estimator keeps the cache. */
    OK(ml_visibility_cache_set_recording(cache, 0));
    OK(ml_visibility_cache_free(cache));
    cache = NULL;
    OK(ml_estimator_set_point(est, &sp, ML_TECHNIQUE_DEFAULT, NULL));
    memset(&s, 0, sizeof s);
    for (k = 0; k < 4000; k++) {
        ml_rgb64 e = {-1, -1, -1};
        OK(ml_estimator_estimate(est, &vis, &u, &e));
        CHECK(estimate_ok(e));
        running_add(&s, e.g);
    }
    running_check(&s, exact, "bl-mis with a learned visibility cache", __LINE__);
    /* Detached: the next set-up samples without it. */
    OK(ml_estimator_set_visibility_cache(est, NULL));
    OK(ml_estimator_set_point(est, &sp, ML_TECHNIQUE_DEFAULT, NULL));
    {
        ml_rgb64 e = {-1, -1, -1};
        OK(ml_estimator_estimate(est, &vis, &u, &e));
        CHECK(estimate_ok(e));
    }
    OK(ml_estimator_free(est));
    OK(ml_tree_free(tree));
}

/* Every function of the cache with a NULL and an invalid value. */
static void bad_input_visibility_cache(void) {
    ml_light ls[VIS_LIGHTS];
    ml_tree *tree, *other;
    ml_visibility_cache_options o;
    ml_visibility_cache *cache = NULL, *foreign = NULL;
    ml_visibility_cache_counts c;
    ml_estimator *est = NULL;
    ml_shading_point sp;
    size_t bytes = 0;
    vis_scene(ls, 0.5f);
    tree = build_tree(ls, VIS_LIGHTS);
    other = build_tree(ls, VIS_LIGHTS);
    sp = direct_point(0.5f);

    BAD_NULL(ml_visibility_cache_options_default, ml_visibility_cache_options_default(1, NULL),
             "`out` is NULL");
    BAD_VALUE(ml_visibility_cache_options_default,
              ml_visibility_cache_options_default(1, MISALIGN(ml_visibility_cache_options, &o)),
              ML_ERR_INVALID_ARGUMENT, "`out` is misaligned");
    OK(ml_visibility_cache_options_default(1, &o));
    BAD_NULL(ml_visibility_cache_create, ml_visibility_cache_create(NULL, &o, &cache),
             "`tree` is NULL");
    BAD_NULL(ml_visibility_cache_create, ml_visibility_cache_create(tree, NULL, &cache),
             "`options` is NULL");
    o.cell_size = -1;
    BAD_VALUE(ml_visibility_cache_create, ml_visibility_cache_create(tree, &o, &cache),
              ML_ERR_INVALID_ARGUMENT, "options.cell_size must be finite and positive (got -1)");
    o.cell_size = 1;
    o.cells = 100;
    BAD_VALUE(ml_visibility_cache_create, ml_visibility_cache_create(tree, &o, &cache),
              ML_ERR_INVALID_ARGUMENT, "options.cells must be a power of two");
    o.cells = 16;
    o.slots = ML_MAX_VISIBILITY_SLOTS * 2;
    BAD_VALUE(ml_visibility_cache_create, ml_visibility_cache_create(tree, &o, &cache),
              ML_ERR_INVALID_ARGUMENT, "options.slots must be a power of two");
    o.slots = 16;
    o.floor = 0;
    BAD_VALUE(ml_visibility_cache_create, ml_visibility_cache_create(tree, &o, &cache),
              ML_ERR_INVALID_ARGUMENT, "options.floor must be in (0, 1] (got 0)");
    CHECK(cache == NULL);
    o.floor = 0.25f;
    OK(ml_visibility_cache_create(tree, &o, &cache));
    OK(ml_visibility_cache_create(other, &o, &foreign));
    FREE_NULL(ml_visibility_cache_free, ml_visibility_cache_free(NULL));
    BAD_VALUE(ml_visibility_cache_free,
              ml_visibility_cache_free(MISALIGN(ml_visibility_cache, cache)),
              ML_ERR_INVALID_ARGUMENT, "`cache` is misaligned");
    BAD_NULL(ml_visibility_cache_commit, ml_visibility_cache_commit(NULL), "`cache` is NULL");
    BAD_VALUE(ml_visibility_cache_commit,
              ml_visibility_cache_commit(MISALIGN(ml_visibility_cache, cache)),
              ML_ERR_INVALID_ARGUMENT, "`cache` is misaligned");
    BAD_NULL(ml_visibility_cache_clear, ml_visibility_cache_clear(NULL), "`cache` is NULL");
    BAD_VALUE(ml_visibility_cache_clear,
              ml_visibility_cache_clear(MISALIGN(ml_visibility_cache, cache)),
              ML_ERR_INVALID_ARGUMENT, "`cache` is misaligned");
    BAD_NULL(ml_visibility_cache_set_recording, ml_visibility_cache_set_recording(NULL, 1),
             "`cache` is NULL");
    BAD_VALUE(ml_visibility_cache_set_recording, ml_visibility_cache_set_recording(cache, 2),
              ML_ERR_INVALID_ARGUMENT, "on must be 0 or 1 (got 2)");
    BAD_NULL(ml_visibility_cache_stats, ml_visibility_cache_stats(cache, NULL), "`out` is NULL");
    BAD_VALUE(ml_visibility_cache_stats,
              ml_visibility_cache_stats(cache, MISALIGN(ml_visibility_cache_counts, &c)),
              ML_ERR_INVALID_ARGUMENT, "`out` is misaligned");
    BAD_NULL(ml_visibility_cache_bytes, ml_visibility_cache_bytes(NULL, &bytes), "`cache` is NULL");
    BAD_VALUE(ml_visibility_cache_bytes,
              ml_visibility_cache_bytes(cache, MISALIGN(size_t, &bytes)),
              ML_ERR_INVALID_ARGUMENT, "`out` is misaligned");

    OK(ml_estimator_create(tree, &est));
    BAD_NULL(ml_estimator_set_visibility_cache, ml_estimator_set_visibility_cache(NULL, cache),
             "`est` is NULL");
    BAD_VALUE(ml_estimator_set_visibility_cache, ml_estimator_set_visibility_cache(est, foreign),
              ML_ERR_INVALID_ARGUMENT, "cache: made for another tree");
    OK(ml_estimator_set_visibility_cache(est, cache));
    BAD_NULL(ml_estimator_record, ml_estimator_record(NULL, 1), "`est` is NULL");
    BAD_VALUE(ml_estimator_record, ml_estimator_record(est, 1), ML_ERR_STATE, "est: not set up");
    OK(ml_estimator_set_point(est, &sp, ML_TECHNIQUE_DEFAULT, NULL));
    BAD_VALUE(ml_estimator_record, ml_estimator_record(est, 1), ML_ERR_STATE,
              "est: no light step to record");
    BAD_VALUE(ml_estimator_record, ml_estimator_record(est, 2), ML_ERR_INVALID_ARGUMENT,
              "visible must be 0 or 1 (got 2)");
    OK(ml_estimator_free(est));
    OK(ml_visibility_cache_free(foreign));
    OK(ml_visibility_cache_free(cache));
    OK(ml_tree_free(other));
    OK(ml_tree_free(tree));
}

#endif
