/*
 * The scenarios of the C ABI's tests, written once in the common subset of C99 and C++17 and
 * compiled into both test programs (test_abi.c, test_abi.cpp) with -Wall -Wextra -Werror.
 *
 * Every check failure is printed with its line and counted; a program exits non-zero if any
 * failed. Bad-input checks are recorded per function ("cover" lines on stdout), which the
 * Rust harness compares with the functions the header declares.
 */
#ifndef ML_TEST_SCENARIOS_H
#define ML_TEST_SCENARIOS_H

#include "manylights.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ML_PI 3.14159265358979323846

static int g_failures = 0;

#define CHECK(cond)                                                                       \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond);      \
            g_failures++;                                                                 \
        }                                                                                 \
    } while (0)

#define OK(call)                                                                          \
    do {                                                                                  \
        ml_status s_ = (call);                                                            \
        if (s_ != ML_OK) {                                                                \
            fprintf(stderr, "%s:%d: %s failed with %d: %s\n", __FILE__, __LINE__, #call,  \
                    (int)s_, ml_last_error_message());                                    \
            g_failures++;                                                                 \
        }                                                                                 \
    } while (0)

/* ---- deterministic numbers ---------------------------------------------------------- */

typedef struct rng {
    uint64_t s;
} rng;

static uint64_t rng_next(rng *r) {
    uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1) with 24 bits. */
static float rng_f32(rng *r) { return (float)(rng_next(r) >> 40) * (1.0f / 16777216.0f); }

/* Uniform in [0, 1) with 53 bits. */
static double rng_f64(rng *r) { return (double)(rng_next(r) >> 11) * (1.0 / 9007199254740992.0); }

static float rng_range(rng *r, float a, float b) { return a + (b - a) * rng_f32(r); }

static float cb_f32(void *user) { return rng_f32((rng *)user); }
static double cb_f64(void *user) { return rng_f64((rng *)user); }

static ml_uniforms uniforms_of(rng *r) {
    ml_uniforms u;
    memset(&u, 0, sizeof u);
    u.next_f32 = cb_f32;
    u.next_f64 = cb_f64;
    u.user_data = r;
    return u;
}

static ml_rgb rgb(float r, float g, float b) {
    ml_rgb c;
    c.r = r;
    c.g = g;
    c.b = b;
    return c;
}

static ml_rgb grey(float v) { return rgb(v, v, v); }

static ml_vec3 v3(float x, float y, float z) {
    ml_vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

static uint32_t bits(float f) {
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    return b;
}

/* ---- scenes -------------------------------------------------------------------------- */

/* Light i of a seeded set: every kind in turn, above the plane z = 0 region. */
static ml_light make_light(rng *r, size_t i) {
    ml_light l;
    ml_vec3 p;
    ml_rgb e;
    memset(&l, 0, sizeof l);
    l.kind = (uint32_t)(i % 6);
    p = v3(rng_range(r, -10, 10), rng_range(r, -10, 10), rng_range(r, 1, 6));
    e = rgb(rng_range(r, 0.1f, 2.0f), rng_range(r, 0.1f, 2.0f), rng_range(r, 0.1f, 2.0f));
    switch (l.kind) {
    case ML_LIGHT_KIND_POINT:
        l.point.position = p;
        l.point.intensity = e;
        break;
    case ML_LIGHT_KIND_SPOT:
        l.spot.position = p;
        l.spot.intensity = e;
        l.spot.axis = v3(rng_range(r, -0.5f, 0.5f), rng_range(r, -0.5f, 0.5f), -1.0f);
        l.spot.half_angle = rng_range(r, 0.2f, 1.2f);
        l.spot.falloff_start = l.spot.half_angle * 0.5f;
        break;
    case ML_LIGHT_KIND_SPHERE:
        l.sphere.center = p;
        l.sphere.radiance = e;
        l.sphere.radius = rng_range(r, 0.02f, 0.2f);
        break;
    case ML_LIGHT_KIND_DISK:
        l.disk.center = p;
        l.disk.radiance = e;
        l.disk.normal = v3(rng_range(r, -0.3f, 0.3f), rng_range(r, -0.3f, 0.3f), -1.0f);
        l.disk.radius = rng_range(r, 0.05f, 0.3f);
        l.disk.two_sided = (uint32_t)(i / 6 % 2);
        break;
    case ML_LIGHT_KIND_TRIANGLE:
        l.triangle.v0 = p;
        l.triangle.radiance = e;
        l.triangle.v1 = v3(p.x + rng_range(r, 0.1f, 0.4f), p.y, p.z + rng_range(r, -0.1f, 0.1f));
        l.triangle.v2 = v3(p.x, p.y + rng_range(r, 0.1f, 0.4f), p.z);
        l.triangle.two_sided = (uint32_t)(i / 6 % 2);
        break;
    case ML_LIGHT_KIND_VPL:
        l.vpl.position = p;
        l.vpl.intensity = e;
        l.vpl.normal = v3(rng_range(r, -0.5f, 0.5f), rng_range(r, -0.5f, 0.5f), -1.0f);
        break;
    default:
        break;
    }
    return l;
}

/* The first point of a light (position, centre or vertex 0; a distant light's direction),
 * for scenarios that move a light. */
static ml_vec3 *light_origin(ml_light *l) {
    switch (l->kind) {
    case ML_LIGHT_KIND_SPOT: return &l->spot.position;
    case ML_LIGHT_KIND_SPHERE: return &l->sphere.center;
    case ML_LIGHT_KIND_DISK: return &l->disk.center;
    case ML_LIGHT_KIND_TRIANGLE: return &l->triangle.v0;
    case ML_LIGHT_KIND_VPL: return &l->vpl.position;
    case ML_LIGHT_KIND_DISTANT: return &l->distant.direction;
    default: return &l->point.position;
    }
}

static ml_light *make_lights(size_t n, uint64_t seed) {
    rng r;
    size_t i;
    ml_light *ls = (ml_light *)malloc(n * sizeof(ml_light));
    r.s = seed;
    for (i = 0; i < n; i++) ls[i] = make_light(&r, i);
    return ls;
}

static ml_tl_point make_tl_point(rng *r) {
    ml_tl_point p;
    p.receiver = ML_RECEIVER_REFLECTIVE;
    p.position = v3(rng_range(r, -11, 11), rng_range(r, -11, 11), rng_range(r, -0.5f, 0.5f));
    p.normal = v3(rng_range(r, -0.4f, 0.4f), rng_range(r, -0.4f, 0.4f), 1.0f);
    return p;
}

static ml_material lambert(float albedo) {
    ml_material m;
    memset(&m, 0, sizeof m);
    m.kind = ML_MATERIAL_KIND_LAMBERT;
    m.albedo = grey(albedo);
    return m;
}

static ml_material plastic(float albedo, float specular, float alpha) {
    ml_material m;
    m.kind = ML_MATERIAL_KIND_PLASTIC;
    m.albedo = grey(albedo);
    m.specular = specular;
    m.alpha = alpha;
    return m;
}

static ml_shading_point make_sp(rng *r) {
    ml_shading_point sp;
    ml_tl_point p = make_tl_point(r);
    sp.position = p.position;
    sp.normal = p.normal;
    sp.wo = v3(rng_range(r, -1, 1), rng_range(r, -1, 1), 1.0f);
    sp.material = plastic(rng_range(r, 0.1f, 0.9f), rng_range(r, 0.0f, 1.0f),
                          rng_range(r, 0.05f, 1.0f));
    return sp;
}

static ml_tree *build_tree(const ml_light *lights, size_t n) {
    ml_tree *tree = NULL;
    OK(ml_tree_build(lights, n, NULL, NULL, &tree));
    return tree;
}

/* ---- bad-input bookkeeping ----------------------------------------------------------- */

typedef struct coverage {
    const char *name;
    int nulls;
    int invalids;
} coverage;

static coverage g_cov[160];
static int g_ncov = 0;

static void record(const char *fn, int invalid) {
    int i;
    for (i = 0; i < g_ncov; i++) {
        if (strcmp(g_cov[i].name, fn) == 0) break;
    }
    if (i == g_ncov) {
        if (g_ncov == (int)(sizeof g_cov / sizeof g_cov[0])) return;
        g_cov[g_ncov].name = fn;
        g_cov[g_ncov].nulls = 0;
        g_cov[g_ncov].invalids = 0;
        g_ncov++;
    }
    if (invalid) {
        g_cov[i].invalids++;
    } else {
        g_cov[i].nulls++;
    }
}

/* The call returned `want` and the message starts with "fn: " and contains `part`. */
static void bad_check(const char *fn, int invalid, ml_status got, ml_status want, const char *part,
                      int line) {
    const char *msg = ml_last_error_message();
    size_t n = strlen(fn);
    record(fn, invalid);
    if (got != want) {
        fprintf(stderr, "line %d: %s returned %d, expected %d (message: %s)\n", line, fn, (int)got,
                (int)want, msg);
        g_failures++;
        return;
    }
    if (want == ML_OK) return;
    if (strncmp(msg, fn, n) != 0 || msg[n] != ':' || strstr(msg, part) == NULL) {
        fprintf(stderr, "line %d: %s: message \"%s\" lacks \"%s\"\n", line, fn, msg, part);
        g_failures++;
    }
}

/* A NULL argument: ML_ERR_NULL naming it. */
#define BAD_NULL(fn, call, part) bad_check(#fn, 0, (call), ML_ERR_NULL, part, __LINE__)
/* An invalid value: `status` with a message containing `part`. */
#define BAD_VALUE(fn, call, status, part) bad_check(#fn, 1, (call), status, part, __LINE__)
/* A free function given NULL: accepted. */
#define FREE_NULL(fn, call) bad_check(#fn, 0, (call), ML_OK, "", __LINE__)
/* A pointer one byte past an aligned object: misaligned for any T of alignment > 1. */
#define MISALIGN(T, p) ((T *)(void *)((char *)(p) + 1))

static void print_coverage(void) {
    int i, total = 0;
    for (i = 0; i < g_ncov; i++) {
        printf("cover %s %d %d\n", g_cov[i].name, g_cov[i].nulls, g_cov[i].invalids);
        total += g_cov[i].nulls + g_cov[i].invalids;
    }
    printf("bad-input checks: %d over %d functions\n", total, g_ncov);
}

/* ---- sampling from a shared tree ------------------------------------------------------ */

typedef struct sample_job {
    const ml_tree *tree;
    uint64_t seed;
    size_t points;
    int failures;
    double checksum;
} sample_job;

#define JOB_CHECK(job, cond)                                                              \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond);      \
            (job)->failures++;                                                            \
        }                                                                                 \
    } while (0)

#define BATCH 128

/* One thread's work on the shared tree: TL and BL samples, each equal to its pmf query, and
 * the batch calls equal to the single calls bit for bit; its own error message. */
static void sample_job_run(sample_job *job) {
    rng r;
    ml_tl_point pts[BATCH];
    ml_shading_point sps[BATCH];
    float us[BATCH], pmfs[BATCH];
    uint32_t lights[BATCH];
    ml_sampled_light out[BATCH];
    size_t done = 0, i;
    char expect[64];
    r.s = job->seed;
    while (done < job->points) {
        for (i = 0; i < BATCH; i++) {
            pts[i] = make_tl_point(&r);
            pts[i].receiver = (uint32_t)(i % 3); /* every ml_receiver */
            sps[i] = make_sp(&r);
            us[i] = rng_f32(&r);
        }
        JOB_CHECK(job, ml_tree_sample_tl_batch(job->tree, pts, us, BATCH, out) == ML_OK);
        for (i = 0; i < BATCH; i++) {
            ml_sampled_light s;
            float q = -1;
            JOB_CHECK(job, ml_tree_sample_tl(job->tree, &pts[i], us[i], &s) == ML_OK);
            JOB_CHECK(job, s.light == out[i].light && bits(s.pmf) == bits(out[i].pmf));
            lights[i] = s.light == ML_NO_LIGHT ? 0 : s.light;
            if (s.light != ML_NO_LIGHT) {
                JOB_CHECK(job, s.pmf >= ML_MIN_PMF && s.pmf <= 1);
                JOB_CHECK(job, ml_tree_pmf_tl(job->tree, &pts[i], s.light, &q) == ML_OK);
                JOB_CHECK(job, bits(q) == bits(s.pmf));
                job->checksum += (double)s.pmf;
            } else {
                JOB_CHECK(job, s.pmf == 0);
            }
        }
        JOB_CHECK(job, ml_tree_pmf_tl_batch(job->tree, pts, lights, BATCH, pmfs) == ML_OK);
        for (i = 0; i < BATCH; i++) {
            float q = -1;
            JOB_CHECK(job, ml_tree_pmf_tl(job->tree, &pts[i], lights[i], &q) == ML_OK);
            JOB_CHECK(job, bits(q) == bits(pmfs[i]));
        }
        JOB_CHECK(job, ml_tree_sample_bl_batch(job->tree, sps, us, BATCH, out) == ML_OK);
        for (i = 0; i < BATCH; i++) {
            ml_sampled_light s;
            float q = -1;
            JOB_CHECK(job, ml_tree_sample_bl(job->tree, &sps[i], us[i], &s) == ML_OK);
            JOB_CHECK(job, s.light == out[i].light && bits(s.pmf) == bits(out[i].pmf));
            lights[i] = s.light == ML_NO_LIGHT ? 1 : s.light;
            if (s.light != ML_NO_LIGHT) {
                JOB_CHECK(job, ml_tree_pmf_bl(job->tree, &sps[i], s.light, &q) == ML_OK);
                JOB_CHECK(job, bits(q) == bits(s.pmf) && q > 0);
            }
        }
        JOB_CHECK(job, ml_tree_pmf_bl_batch(job->tree, sps, lights, BATCH, pmfs) == ML_OK);
        for (i = 0; i < BATCH; i++) {
            float q = -1;
            JOB_CHECK(job, ml_tree_pmf_bl(job->tree, &sps[i], lights[i], &q) == ML_OK);
            JOB_CHECK(job, bits(q) == bits(pmfs[i]));
        }
        done += BATCH;
    }
    /* The last error message is this thread's own. */
    snprintf(expect, sizeof expect, "(got %llu)", (unsigned long long)(job->seed % 1000 + 2));
    JOB_CHECK(job, ml_tree_sample_tl(job->tree, &pts[0], (float)(job->seed % 1000 + 2), out) ==
                       ML_ERR_INVALID_ARGUMENT);
    JOB_CHECK(job, strstr(ml_last_error_message(), expect) != NULL);
}

/* ---- pmf consistency with the Rust core: a dump the Rust harness replays -------------- */

/* A light as kind, two_sided, then 15 numbers: a point (position, centre or vertex 0), a
 * direction (axis, normal or vertex 1), vertex 2, the intensity, radiance or irradiance, the
 * radius, the half-angle (or angular radius) and the falloff start. */
static void dump_light(FILE *f, const ml_light *l) {
    ml_vec3 z = {0, 0, 0}, p = z, d = z, v2 = z;
    ml_rgb e = {0, 0, 0};
    float radius = 0, half = 0, falloff = 0;
    uint32_t two = 0;
    switch (l->kind) {
    case ML_LIGHT_KIND_POINT:
        p = l->point.position;
        e = l->point.intensity;
        break;
    case ML_LIGHT_KIND_SPOT:
        p = l->spot.position;
        d = l->spot.axis;
        e = l->spot.intensity;
        half = l->spot.half_angle;
        falloff = l->spot.falloff_start;
        break;
    case ML_LIGHT_KIND_SPHERE:
        p = l->sphere.center;
        e = l->sphere.radiance;
        radius = l->sphere.radius;
        break;
    case ML_LIGHT_KIND_DISK:
        p = l->disk.center;
        d = l->disk.normal;
        e = l->disk.radiance;
        radius = l->disk.radius;
        two = l->disk.two_sided;
        break;
    case ML_LIGHT_KIND_TRIANGLE:
        p = l->triangle.v0;
        d = l->triangle.v1;
        v2 = l->triangle.v2;
        e = l->triangle.radiance;
        two = l->triangle.two_sided;
        break;
    case ML_LIGHT_KIND_VPL:
        p = l->vpl.position;
        d = l->vpl.normal;
        e = l->vpl.intensity;
        break;
    case ML_LIGHT_KIND_DISTANT:
        d = l->distant.direction;
        e = l->distant.irradiance;
        half = l->distant.angular_radius;
        break;
    default:
        break;
    }
    fprintf(f,
            "L %u %u %08x %08x %08x %08x %08x %08x %08x %08x %08x %08x %08x %08x %08x %08x "
            "%08x\n",
            (unsigned)l->kind, (unsigned)two, bits(p.x), bits(p.y), bits(p.z), bits(d.x),
            bits(d.y), bits(d.z), bits(v2.x), bits(v2.y), bits(v2.z), bits(e.r), bits(e.g),
            bits(e.b), bits(radius), bits(half), bits(falloff));
}

static void dump_tl(FILE *f, char tag, const ml_tl_point *p, uint32_t x, uint32_t light, float pmf) {
    fprintf(f, "%c %08x %08x %08x %08x %08x %08x %08x %u %u %08x\n", tag, bits(p->position.x),
            bits(p->position.y), bits(p->position.z), bits(p->normal.x), bits(p->normal.y),
            bits(p->normal.z), (unsigned)x, (unsigned)p->receiver, (unsigned)light, bits(pmf));
}

static void dump_sp(FILE *f, char tag, const ml_shading_point *p) {
    fprintf(f, "%c %08x %08x %08x %08x %08x %08x %08x %08x %08x %u %08x %08x %08x %08x %08x",
            tag, bits(p->position.x), bits(p->position.y), bits(p->position.z),
            bits(p->normal.x), bits(p->normal.y), bits(p->normal.z), bits(p->wo.x),
            bits(p->wo.y), bits(p->wo.z), (unsigned)p->material.kind,
            bits(p->material.albedo.r), bits(p->material.albedo.g), bits(p->material.albedo.b),
            bits(p->material.specular), bits(p->material.alpha));
}

static void dump_bl(FILE *f, char tag, const ml_shading_point *p, uint32_t x, uint32_t light,
                    float pmf) {
    dump_sp(f, tag, p);
    fprintf(f, " %08x %u %08x\n", (unsigned)x, (unsigned)light, bits(pmf));
}

/* A BRDF value in colour: F (ml_brdf_eval of the direction `wi`) or G (ml_brdf_sample with
 * the uniform numbers `wi.x`, `wi.y`: the draw's pdf and value). */
static void dump_brdf(FILE *f, char tag, const ml_shading_point *p, ml_vec3 wi, float pdf,
                      ml_rgb value) {
    dump_sp(f, tag, p);
    fprintf(f, " %08x %08x %08x %08x %08x %08x %08x\n", bits(wi.x), bits(wi.y), bits(wi.z),
            bits(pdf), bits(value.r), bits(value.g), bits(value.b));
}

/* Writes the lights, then TL and BL samples (S, B: the u's bits, the light, the pmf), pmf
 * queries (Q, P: the light asked, the pmf; the TL points of every ml_receiver) and BRDF values
 * of RGB albedos (F, G) the Rust harness recomputes with the core. */
static void dump_consistency(const char *path, const ml_tree *tree, const ml_light *lights,
                             size_t n) {
    FILE *f = fopen(path, "w");
    rng r;
    size_t i;
    if (f == NULL) {
        fprintf(stderr, "cannot write %s\n", path);
        g_failures++;
        return;
    }
    r.s = 77;
    for (i = 0; i < n; i++) dump_light(f, &lights[i]);
    for (i = 0; i < 500; i++) {
        ml_tl_point p = make_tl_point(&r);
        ml_shading_point sp = make_sp(&r), rgb_sp = sp;
        float u = rng_f32(&r), q = 0;
        uint32_t l = (uint32_t)(rng_next(&r) % n);
        ml_sampled_light s;
        ml_brdf_draw d;
        ml_rgb value;
        ml_vec3 u2;
        p.receiver = (uint32_t)(i % 3); /* every ml_receiver */
        OK(ml_tree_sample_tl(tree, &p, u, &s));
        dump_tl(f, 'S', &p, bits(u), s.light, s.pmf);
        OK(ml_tree_pmf_tl(tree, &p, l, &q));
        dump_tl(f, 'Q', &p, 0, l, q);
        OK(ml_tree_sample_bl(tree, &sp, u, &s));
        dump_bl(f, 'B', &sp, bits(u), s.light, s.pmf);
        OK(ml_tree_pmf_bl(tree, &sp, l, &q));
        dump_bl(f, 'P', &sp, 0, l, q);
        /* The same point with an RGB albedo (numbers of their own: the others stay as they
         * were): its draw and the value of the drawn direction, per channel. */
        rgb_sp.material.albedo = rgb(0.9f, 0.45f * (float)(i % 3), 0.05f);
        rgb_sp.material.kind = (uint32_t)(i % 2 == 0 ? ML_MATERIAL_KIND_LAMBERT : ML_MATERIAL_KIND_PLASTIC);
        u2 = v3(((float)i + 0.5f) / 500.0f, (float)((i * 37) % 500) / 500.0f, 0);
        OK(ml_brdf_sample(&rgb_sp, u2.x, u2.y, &d));
        dump_brdf(f, 'G', &rgb_sp, u2, d.pdf, d.value);
        if (d.pdf > 0) {
            OK(ml_brdf_eval(&rgb_sp, d.wi, &value));
            dump_brdf(f, 'F', &rgb_sp, d.wi, 0, value);
        } else {
            OK(ml_brdf_eval(&rgb_sp, rgb_sp.normal, &value));
            dump_brdf(f, 'F', &rgb_sp, rgb_sp.normal, 0, value);
        }
    }
    fclose(f);
}

/* ---- the tree: stats, serialization ---------------------------------------------------- */

static void scenario_tree(const ml_tree *tree, size_t n) {
    ml_tree_statistics st;
    size_t size = 0, written = 0;
    uint8_t *buf;
    ml_tree *loaded = NULL;
    rng r;
    int i;
    OK(ml_tree_stats(tree, &st));
    CHECK(st.lights == n);
    CHECK(st.sampled_lights > 0 && st.sampled_lights <= n);
    CHECK(st.nodes > 0 && st.depth > 0 && st.bytes > 0 && st.has_lights == 1);
    CHECK(st.total_energy > 0);

    OK(ml_tree_serialized_size(tree, &size));
    CHECK(size > 0);
    buf = (uint8_t *)malloc(size);
    OK(ml_tree_serialize(tree, buf, size, &written));
    CHECK(written == size);
    OK(ml_tree_load(buf, size, &loaded));
    if (loaded != NULL) {
        OK(ml_tree_stats(loaded, &st));
        CHECK(st.lights == n && st.has_lights == 0);
        r.s = 5;
        for (i = 0; i < 200; i++) {
            ml_tl_point p = make_tl_point(&r);
            float u = rng_f32(&r);
            ml_sampled_light a, b;
            OK(ml_tree_sample_tl(tree, &p, u, &a));
            OK(ml_tree_sample_tl(loaded, &p, u, &b));
            CHECK(a.light == b.light && bits(a.pmf) == bits(b.pmf));
        }
    }
    /* Corrupt bytes: a flipped byte in the header, a truncation. */
    {
        ml_tree *bad = NULL;
        buf[0] ^= 0x5a;
        CHECK(ml_tree_load(buf, size, &bad) == ML_ERR_FORMAT && bad == NULL);
        buf[0] ^= 0x5a;
        buf[8] ^= 0x01;
        CHECK(ml_tree_load(buf, size, &bad) == ML_ERR_FORMAT && bad == NULL);
        buf[8] ^= 0x01;
        CHECK(ml_tree_load(buf, size - 1, &bad) == ML_ERR_FORMAT && bad == NULL);
        CHECK(ml_tree_load(buf, 7, &bad) == ML_ERR_FORMAT && bad == NULL);
    }
    OK(ml_tree_free(loaded));
    free(buf);
}

/* ---- a cached tree: loaded with its lights, corrupt bytes, the wrong lights ------------- */

/* The estimate of technique t at sp with the uniform numbers of `seed`. */
static ml_rgb64 estimate_seeded(const ml_tree *tree, const ml_shading_point *sp, uint32_t t,
                                uint64_t seed) {
    rng r;
    ml_uniforms u = uniforms_of(&r);
    ml_rgb64 e = {-1, -1, -1};
    r.s = seed;
    OK(ml_direct_estimate(tree, sp, t, NULL, NULL, &u, &e));
    return e;
}

/* Whether the last error message contains `part`. */
static int message_has(const char *part) { return strstr(ml_last_error_message(), part) != NULL; }

static void scenario_cache(const ml_tree *tree, const ml_light *lights, size_t n) {
    size_t size = 0, written = 0, i;
    uint8_t *buf;
    ml_tree *loaded = NULL, *bad = NULL;
    ml_tree_statistics st;
    ml_light *wrong = (ml_light *)malloc(n * sizeof(ml_light));
    ml_sampled_light none = ML_SAMPLED_LIGHT_NONE;
    rng r;
    int k;
    uint32_t t;
    long rejected = 0;
    CHECK(none.light == ML_NO_LIGHT && none.pmf == 0);
    OK(ml_tree_serialized_size(tree, &size));
    buf = (uint8_t *)malloc(size);
    OK(ml_tree_serialize(tree, buf, size, &written));
    OK(ml_tree_load_with_lights(buf, size, lights, n, NULL, &loaded));
    if (loaded != NULL) {
        OK(ml_tree_stats(loaded, &st));
        CHECK(st.lights == n && st.has_lights == 1);
        r.s = 404;
        /* Samples, points on lights and every technique: bit for bit the saved tree's. */
        for (k = 0; k < 100; k++) {
            ml_tl_point p = make_tl_point(&r);
            ml_shading_point sp = make_sp(&r);
            float u = rng_f32(&r), u0 = rng_f32(&r), u1 = rng_f32(&r);
            uint32_t l = (uint32_t)(rng_next(&r) % n);
            uint64_t seed = rng_next(&r);
            ml_sampled_light a, b;
            ml_light_point pa, pb;
            OK(ml_tree_sample_bl(tree, &sp, u, &a));
            OK(ml_tree_sample_bl(loaded, &sp, u, &b));
            CHECK(a.light == b.light && bits(a.pmf) == bits(b.pmf));
            OK(ml_tree_sample_tl(tree, &p, u, &a));
            OK(ml_tree_sample_tl(loaded, &p, u, &b));
            CHECK(a.light == b.light && bits(a.pmf) == bits(b.pmf));
            OK(ml_light_sample_point(tree, l, p.position, u0, u1, &pa));
            OK(ml_light_sample_point(loaded, l, p.position, u0, u1, &pb));
            CHECK(memcmp(&pa, &pb, sizeof pa) == 0);
            t = (uint32_t)(k % 9);
            {
                ml_rgb64 ea = estimate_seeded(tree, &sp, t, seed);
                ml_rgb64 eb = estimate_seeded(loaded, &sp, t, seed);
                CHECK(memcmp(&ea, &eb, sizeof ea) == 0);
            }
        }
    }
    /* The wrong lights: the first mismatch is named. */
    memcpy(wrong, lights, n * sizeof(ml_light));
    light_origin(&wrong[123])->z += 1000;
    CHECK(ml_tree_load_with_lights(buf, size, wrong, n, NULL, &bad) == ML_ERR_FORMAT && bad == NULL);
    CHECK(message_has("lights[123] lies outside its slot's bounds"));
    wrong[123] = lights[123];
    CHECK(ml_tree_load_with_lights(buf, size, lights, n - 1, NULL, &bad) == ML_ERR_FORMAT);
    CHECK(message_has("count is 9999, the tree was built from 10000 lights"));
    light_origin(&wrong[100])->x = nextafterf(light_origin(&wrong[100])->x, (float)INFINITY);
    CHECK(ml_tree_load_with_lights(buf, size, wrong, n, NULL, &bad) == ML_ERR_FORMAT);
    CHECK(message_has("lights[100]") || message_has("lights[64..128] differ"));
    wrong[100] = lights[100];
    wrong[0] = lights[n - 1];
    wrong[n - 1] = lights[0];
    CHECK(ml_tree_load_with_lights(buf, size, wrong, n, NULL, &bad) == ML_ERR_FORMAT);
    CHECK(message_has("lights[0"));
    CHECK(bad == NULL);
    /* Corrupt bytes never load: 0xFF into every 97th byte, one at a time, then random flips,
     * replacements and truncations. */
    for (i = 0; i < size; i += 97) {
        buf[i] ^= 0xFF;
        CHECK(ml_tree_load(buf, size, &bad) == ML_ERR_FORMAT && bad == NULL);
        buf[i] ^= 0xFF;
    }
    r.s = 12222;
    for (k = 0; k < 3000; k++) {
        size_t at = (size_t)(rng_next(&r) % size);
        uint8_t old = buf[at], x = (uint8_t)(1u << (rng_next(&r) % 8));
        if (k % 3 == 0) {
            CHECK(ml_tree_load(buf, at, &bad) == ML_ERR_FORMAT && bad == NULL);
            rejected++;
            continue;
        }
        if (k % 3 == 1) x = (uint8_t)(rng_next(&r) | 1);
        buf[at] ^= x;
        if (ml_tree_load(buf, size, &bad) == ML_ERR_FORMAT && bad == NULL) rejected++;
        if (k % 100 == 1) {
            CHECK(ml_tree_load_with_lights(buf, size, lights, n, NULL, &bad) == ML_ERR_FORMAT);
            CHECK(message_has("bytes: tree bytes are corrupt"));
        }
        buf[at] = old;
    }
    CHECK(rejected == 3000);
    OK(ml_tree_load(buf, size, &bad));
    OK(ml_tree_free(bad));
    OK(ml_tree_free(loaded));
    free(wrong);
    free(buf);
}

/* ---- cuts ---------------------------------------------------------------------------- */

static void scenario_cut(const ml_tree *tree, size_t n) {
    ml_cut *cut = NULL;
    rng r;
    int k;
    OK(ml_cut_create(&cut));
    r.s = 99;
    for (k = 0; k < 50; k++) {
        ml_shading_point sp = make_sp(&r);
        ml_tl_point tp;
        size_t size = 0, i;
        float ib = -1;
        float us[ML_CUT_CAPACITY];
        ml_sampled_light out[ML_CUT_CAPACITY];
        OK(ml_cut_build_bl(cut, tree, &sp, NULL));
        OK(ml_cut_size(cut, &size));
        CHECK(size <= ML_CUT_CAPACITY);
        OK(ml_cut_ib(cut, &ib));
        CHECK(ib >= 0 && ib == ib);
        CHECK(ml_cut_max_variance(cut, &ib) == ML_ERR_STATE);
        for (i = 0; i < 20; i++) {
            ml_sampled_light s;
            float q = -1;
            OK(ml_cut_sample(cut, rng_f32(&r), &s));
            if (s.light != ML_NO_LIGHT) {
                CHECK(s.light < n);
                OK(ml_cut_pmf(cut, s.light, &q));
                CHECK(bits(q) == bits(s.pmf) && q > 0);
            }
        }
        tp.position = sp.position;
        tp.normal = sp.normal;
        tp.receiver = ML_RECEIVER_REFLECTIVE;
        OK(ml_cut_build_split(cut, tree, &tp, NULL));
        OK(ml_cut_size(cut, &size));
        CHECK(size >= 1 && size <= 32);
        ib = -1;
        OK(ml_cut_max_variance(cut, &ib));
        CHECK(ib >= 0 && ib == ib);
        CHECK(ml_cut_ib(cut, &ib) == ML_ERR_STATE);
        for (i = 0; i < size; i++) us[i] = rng_f32(&r);
        OK(ml_cut_sample_clusters(cut, us, size, out));
        for (i = 0; i < size; i++) {
            uint32_t cluster = 99;
            float q = -1;
            if (out[i].light == ML_NO_LIGHT) continue;
            OK(ml_cut_pmf_in(cut, out[i].light, &cluster, &q));
            CHECK(cluster == (uint32_t)i && bits(q) == bits(out[i].pmf) && q > 0);
        }
    }
    OK(ml_cut_free(cut));
}

/* f·L·cos θ / pdf (red) at the origin (normal +z, Lambert of albedo rho) of light `light` that
 * a cut gave: a point on it, or for the environment (index `sky`, radiance `sky_l`) a
 * direction the host samples uniformly over the sphere. */
static double cut_host_contribution(const ml_tree *tree, uint32_t light, uint32_t sky,
                                    float sky_l, float rho, float u0, float u1) {
    double f = rho / ML_PI;
    ml_light_point p;
    if (light == sky) {
        double z = 1 - 2 * (double)u0;
        return z > 0 ? f * sky_l * z * (4 * ML_PI) : 0;
    }
    OK(ml_light_sample_point(tree, light, v3(0, 0, 0), u0, u1, &p));
    if (!(p.pdf > 0) || p.direction.z <= 0) return 0;
    return f * p.radiance.r * p.direction.z / p.pdf;
}

/* Mean within 5 standard errors (plus 1e-4 relative) of `exact`. */
static void cut_check_mean(double sum, double sum2, long n, double exact, const char *what) {
    double mean = sum / (double)n;
    double var = (sum2 / (double)n - mean * mean) * (double)n / (double)(n - 1);
    double se = sqrt(var > 0 ? var : 0) / sqrt((double)n);
    if (fabs(mean - exact) > 5 * se + 1e-4 * exact) {
        fprintf(stderr, "%s: mean %.6g, exact %.6g, 1 se %.3g (n = %ld)\n", what, mean, exact, se,
                n);
        g_failures++;
    }
}

/* The uniform grey sky of scenario_cut_infinite (radiance in *user), sampled uniformly over
 * the sphere. */
static int32_t grey_sky_sample(void *user, float u0, float u1, ml_vec3 *d, ml_rgb *radiance,
                               float *pdf) {
    float z = 1 - 2 * u0, r = sqrtf(1 - z * z > 0 ? 1 - z * z : 0), phi = 2 * (float)ML_PI * u1;
    *d = v3(r * cosf(phi), r * sinf(phi), z);
    *radiance = grey(*(const float *)user);
    *pdf = 1 / (4 * (float)ML_PI);
    return 1;
}

static void grey_sky_eval(void *user, ml_vec3 d, ml_rgb *radiance, float *pdf) {
    (void)d;
    *radiance = grey(*(const float *)user);
    *pdf = 1 / (4 * (float)ML_PI);
}

/* A host's own sampling of the cuts of a tree with a sun, a sky and a sphere light on a
 * Lambert plane of albedo 0.8: the cuts hold the sun and the sky as clusters of their own,
 * and one light of the whole cut (ml_cut_sample) or one per cluster (ml_cut_sample_clusters)
 * is unbiased against the closed form; a sun below the horizon alone leaves the cut empty. */
static void scenario_cut_infinite(void) {
    const float rho = 0.8f, sky_l = 0.3f, sun_e = 2.0f, sph_l = 4.0f, sph_r = 0.3f;
    const ml_vec3 sun_dir = {0.3f, -0.2f, 1.0f}, c = {0.5f, -0.3f, 2.0f};
    ml_light ls[2];
    ml_environment env;
    ml_tree *tree = NULL;
    ml_cut *cut = NULL;
    ml_shading_point sp;
    ml_tl_point tp;
    double exact, d, sum, sum2;
    size_t size = 0, i, j;
    int pass;
    long k;
    rng r;
    r.s = 4242;
    memset(ls, 0, sizeof ls);
    ls[0].distant.kind = ML_LIGHT_KIND_DISTANT;
    ls[0].distant.direction = sun_dir;
    ls[0].distant.angular_radius = 0.0047f;
    ls[0].distant.irradiance = grey(sun_e);
    ls[1].sphere.kind = ML_LIGHT_KIND_SPHERE;
    ls[1].sphere.center = c;
    ls[1].sphere.radius = sph_r;
    ls[1].sphere.radiance = grey(sph_l);
    /* The sky, light 2: one past the array. */
    memset(&env, 0, sizeof env);
    env.sample = grey_sky_sample;
    env.eval = grey_sky_eval;
    env.user_data = (void *)&sky_l;
    for (i = 0; i < 6; i++) env.irradiance_bounds[i] = (float)(ML_PI * sky_l * 1.0001);
    d = sqrt(0.25 + 0.09 + 4.0);
    exact = rho / ML_PI * sun_e / sqrt(0.09 + 0.04 + 1.0) + rho * sky_l +
            rho * sph_l * sph_r * sph_r / (d * d) * 2.0 / d;
    OK(ml_tree_build(ls, 2, &env, NULL, &tree));
    {
        /* The sun and the sky are sampled lights too. */
        ml_tree_statistics st;
        OK(ml_tree_stats(tree, &st));
        CHECK(st.lights == 3 && st.sampled_lights == 3);
    }
    sp.position = v3(0, 0, 0);
    sp.normal = v3(0, 0, 1);
    sp.wo = v3(0.2f, 0.1f, 1);
    sp.material = lambert(rho);
    tp.position = v3(0, 0, 0);
    tp.normal = v3(0, 0, 1);
    tp.receiver = ML_RECEIVER_REFLECTIVE;
    OK(ml_cut_create(&cut));
    for (pass = 0; pass < 2; pass++) {
        float us[ML_CUT_CAPACITY];
        ml_sampled_light out[ML_CUT_CAPACITY];
        if (pass == 0) {
            OK(ml_cut_build_bl(cut, tree, &sp, NULL));
        } else {
            OK(ml_cut_build_split(cut, tree, &tp, NULL));
        }
        OK(ml_cut_size(cut, &size));
        CHECK(size == 3);
        if (size != 3) continue;
        /* One light of the whole cut. */
        sum = sum2 = 0;
        for (k = 0; k < 40000; k++) {
            ml_sampled_light s;
            float q = -1;
            double v = 0;
            OK(ml_cut_sample(cut, rng_f32(&r), &s));
            if (s.light != ML_NO_LIGHT) {
                OK(ml_cut_pmf(cut, s.light, &q));
                CHECK(bits(q) == bits(s.pmf) && q > 0);
                v = cut_host_contribution(tree, s.light, 2, sky_l, rho, rng_f32(&r), rng_f32(&r)) /
                    s.pmf;
            }
            sum += v;
            sum2 += v * v;
        }
        cut_check_mean(sum, sum2, 40000, exact, pass ? "ml_cut_sample (split cut)"
                                                     : "ml_cut_sample (BL cut)");
        /* One light in each cluster. */
        sum = sum2 = 0;
        for (k = 0; k < 10000; k++) {
            double v = 0;
            for (j = 0; j < size; j++) us[j] = rng_f32(&r);
            OK(ml_cut_sample_clusters(cut, us, size, out));
            for (j = 0; j < size; j++) {
                uint32_t cluster = 99;
                float q = -1;
                CHECK(out[j].light != ML_NO_LIGHT);
                if (out[j].light == ML_NO_LIGHT) continue;
                OK(ml_cut_pmf_in(cut, out[j].light, &cluster, &q));
                CHECK(cluster == (uint32_t)j && bits(q) == bits(out[j].pmf) && q > 0);
                v += cut_host_contribution(tree, out[j].light, 2, sky_l, rho, rng_f32(&r),
                                           rng_f32(&r)) /
                     out[j].pmf;
            }
            sum += v;
            sum2 += v * v;
        }
        cut_check_mean(sum, sum2, 10000, exact, pass ? "ml_cut_sample_clusters (split cut)"
                                                     : "ml_cut_sample_clusters (BL cut)");
    }
    OK(ml_tree_free(tree));
    /* A sun below the horizon alone. */
    ls[0].distant.direction = v3(0.2f, 0, -1);
    tree = build_tree(ls, 1);
    OK(ml_cut_build_split(cut, tree, &tp, NULL));
    OK(ml_cut_size(cut, &size));
    CHECK(size == 0);
    OK(ml_cut_build_bl(cut, tree, &sp, NULL));
    OK(ml_cut_size(cut, &size));
    CHECK(size == 0);
    OK(ml_tree_free(tree));
    OK(ml_cut_free(cut));
}

/* A sun whose cone is too narrow for f32 (1e-20 rad with E = 2, 1e-10 rad with E = 1e20) is
 * a delta direction: its point has pdf 1 and radiance E, and every technique's estimate on a
 * Lambert plane of albedo 0.8 facing it is 0.8·E·cos θ / π. */
static void scenario_narrow_sun(void) {
    const float gammas[2] = {1e-20f, 1e-10f}, es[2] = {2.0f, 1e20f};
    int g;
    for (g = 0; g < 2; g++) {
        ml_light sun;
        ml_tree *tree;
        ml_light_point p;
        ml_shading_point sp;
        double exact = 0.8 / ML_PI * es[g] / sqrt(0.09 + 0.04 + 1.0);
        uint32_t t;
        rng r;
        ml_uniforms u = uniforms_of(&r);
        r.s = 777;
        memset(&sun, 0, sizeof sun);
        sun.distant.kind = ML_LIGHT_KIND_DISTANT;
        sun.distant.direction = v3(0.3f, -0.2f, 1.0f);
        sun.distant.angular_radius = gammas[g];
        sun.distant.irradiance = grey(es[g]);
        tree = build_tree(&sun, 1);
        OK(ml_light_sample_point(tree, 0, v3(0, 0, 0), 0.3f, 0.7f, &p));
        CHECK(p.pdf == 1 && p.delta == 1 && p.radiance.r == es[g]);
        sp.position = v3(0, 0, 0);
        sp.normal = v3(0, 0, 1);
        sp.wo = v3(0.1f, 0.2f, 1);
        sp.material = lambert(0.8f);
        for (t = 0; t < 10; t++) {
            double sum = 0, sum2 = 0;
            long k;
            for (k = 0; k < 500; k++) {
                ml_rgb64 e = {-1, -1, -1};
                OK(ml_direct_estimate(tree, &sp, t, NULL, NULL, &u, &e));
                sum += e.r;
                sum2 += e.r * e.r;
            }
            cut_check_mean(sum, sum2, 500, exact, "a sun too narrow for f32");
        }
        OK(ml_tree_free(tree));
    }
}

/* ---- points on lights, BRDFs ---------------------------------------------------------- */

static void scenario_points(const ml_tree *tree, const ml_light *lights, size_t n) {
    rng r;
    int k;
    r.s = 1234;
    for (k = 0; k < 300; k++) {
        uint32_t l = (uint32_t)(rng_next(&r) % n);
        ml_vec3 x = v3(rng_range(&r, -5, 5), rng_range(&r, -5, 5), 0);
        ml_light_point p;
        OK(ml_light_sample_point(tree, l, x, rng_f32(&r), rng_f32(&r), &p));
        if (p.pdf > 0) {
            float q = -1;
            CHECK(p.distance > 0 && p.radiance.r >= 0 && p.radiance.g >= 0 && p.radiance.b >= 0);
            OK(ml_light_pdf_point(tree, l, x, p.position, &q));
            if (p.delta) {
                /* One convention: the delta's weight, reported as 1, at its position. */
                CHECK(q == 1 && p.pdf == 1);
            } else if (lights[l].kind == ML_LIGHT_KIND_SPHERE || lights[l].kind == ML_LIGHT_KIND_DISK) {
                CHECK(fabs(q - p.pdf) <= 1e-2 * p.pdf);
            }
        }
    }
    for (k = 0; k < 300; k++) {
        ml_shading_point sp = make_sp(&r);
        ml_brdf_draw d;
        OK(ml_brdf_sample(&sp, rng_f32(&r), rng_f32(&r), &d));
        if (d.pdf > 0) {
            float q = -1;
            ml_rgb f = rgb(-1, -1, -1);
            OK(ml_brdf_pdf(&sp, d.wi, &q));
            OK(ml_brdf_eval(&sp, d.wi, &f));
            CHECK(fabs(q - d.pdf) <= 1e-3 * d.pdf);
            CHECK(fabs(f.r - d.value.r) <= 1e-3 * d.value.r + 1e-6);
            CHECK(fabs(f.g - d.value.g) <= 1e-3 * d.value.g + 1e-6);
            CHECK(fabs(f.b - d.value.b) <= 1e-3 * d.value.b + 1e-6);
            /* A grey albedo: the same f in every channel. */
            CHECK(f.r == f.g && f.g == f.b && d.value.r == d.value.g && d.value.g == d.value.b);
        }
    }
    /* An RGB albedo: a Lambert surface's f is each channel's albedo / π (the dump's F and G
     * records check every bit against the core's Material::eval_rgb). */
    {
        ml_shading_point sp;
        ml_rgb f = rgb(-1, -1, -1);
        ml_brdf_draw d;
        memset(&sp, 0, sizeof sp);
        sp.normal = v3(0, 0, 1);
        sp.wo = v3(0.3f, 0, 1);
        sp.material.kind = ML_MATERIAL_KIND_LAMBERT;
        sp.material.albedo = rgb(0.8f, 0.4f, 0.1f);
        OK(ml_brdf_eval(&sp, v3(-0.2f, 0.1f, 1), &f));
        CHECK(fabs(f.r - 0.8 / ML_PI) <= 1e-6 && fabs(f.g - 0.4 / ML_PI) <= 1e-6 &&
              fabs(f.b - 0.1 / ML_PI) <= 1e-6);
        OK(ml_brdf_sample(&sp, 0.3f, 0.6f, &d));
        CHECK(d.pdf > 0 && d.value.r == f.r && d.value.g == f.g && d.value.b == f.b);
    }
}

/* ---- the receiver of a TL point --------------------------------------------------------- */

/* A point light below a surface facing up: a reflective point gets no light, a transmissive
 * (two-sided) or omnidirectional one gets it with pmf 1, in the single calls, the batches and
 * the split cut (the dump's Q and S records check the pmfs of every receiver against the
 * core's TlImportance bit for bit). */
static void scenario_receiver(void) {
    ml_light l;
    ml_tree *tree = NULL;
    ml_cut *cut = NULL;
    ml_tl_point pts[3];
    ml_sampled_light s, outs[3];
    float us[3] = {0.5f, 0.5f, 0.5f}, pmfs[3] = {-1, -1, -1}, q = -1;
    uint32_t zero[3] = {0, 0, 0};
    size_t size = 99;
    int i;
    memset(&l, 0, sizeof l);
    l.point.kind = ML_LIGHT_KIND_POINT;
    l.point.position = v3(0.2f, 0.1f, -1);
    l.point.intensity = grey(1);
    OK(ml_tree_build(&l, 1, NULL, NULL, &tree));
    OK(ml_cut_create(&cut));
    for (i = 0; i < 3; i++) {
        memset(&pts[i], 0, sizeof pts[i]);
        pts[i].normal = v3(0, 0, 1);
    }
    pts[0].receiver = ML_RECEIVER_REFLECTIVE;
    pts[1].receiver = ML_RECEIVER_TRANSMISSIVE;
    pts[2].receiver = ML_RECEIVER_OMNIDIRECTIONAL;
    OK(ml_tree_sample_tl_batch(tree, pts, us, 3, outs));
    OK(ml_tree_pmf_tl_batch(tree, pts, zero, 3, pmfs));
    for (i = 0; i < 3; i++) {
        OK(ml_tree_sample_tl(tree, &pts[i], 0.5f, &s));
        OK(ml_tree_pmf_tl(tree, &pts[i], 0, &q));
        OK(ml_cut_build_split(cut, tree, &pts[i], NULL));
        OK(ml_cut_size(cut, &size));
        if (i == 0) {
            CHECK(s.light == ML_NO_LIGHT && q == 0 && size == 0);
        } else {
            CHECK(s.light == 0 && s.pmf == 1 && q == 1 && size == 1);
        }
        CHECK(outs[i].light == s.light && bits(outs[i].pmf) == bits(s.pmf));
        CHECK(bits(pmfs[i]) == bits(q));
    }
    OK(ml_cut_free(cut));
    OK(ml_tree_free(tree));
}

/* ---- direct lighting against a closed form --------------------------------------------- */

/* 40 sphere lights and 10 point lights above the point (0, 0, 0) with normal +z, all entirely
 * above its horizon, in colour (each channel of each light drawn on its own): the radiance a
 * Lambert surface of albedo rho reflects is, per channel,
 *   sum over spheres of rho · L · (r/d)² · cos θ  (irradiance π L sin²α cos θ)
 *   + sum over points of rho/π · I · cos θ / d². */
#define DIRECT_LIGHTS 50

static void direct_scene(ml_light *ls, float rho, double exact[3]) {
    rng r;
    int i, c;
    r.s = 4242;
    exact[0] = exact[1] = exact[2] = 0;
    for (i = 0; i < DIRECT_LIGHTS; i++) {
        ml_light l;
        ml_vec3 p;
        ml_rgb e;
        float radius = 0;
        double d, cos_t, power[3];
        memset(&l, 0, sizeof l);
        p = v3(rng_range(&r, -3, 3), rng_range(&r, -3, 3), rng_range(&r, 1.5f, 4));
        d = sqrt((double)p.x * p.x + (double)p.y * p.y + (double)p.z * p.z);
        cos_t = p.z / d;
        if (i % 5 == 4) {
            e = rgb(rng_range(&r, 0.5f, 2), rng_range(&r, 0.5f, 2), rng_range(&r, 0.5f, 2));
            l.point.kind = ML_LIGHT_KIND_POINT;
            l.point.position = p;
            l.point.intensity = e;
        } else {
            radius = rng_range(&r, 0.05f, 0.2f);
            e = rgb(rng_range(&r, 0.5f, 3), rng_range(&r, 0.5f, 3), rng_range(&r, 0.5f, 3));
            l.sphere.kind = ML_LIGHT_KIND_SPHERE;
            l.sphere.center = p;
            l.sphere.radius = radius;
            l.sphere.radiance = e;
        }
        power[0] = e.r;
        power[1] = e.g;
        power[2] = e.b;
        for (c = 0; c < 3; c++) {
            if (l.kind == ML_LIGHT_KIND_POINT)
                exact[c] += rho / ML_PI * power[c] * cos_t / (d * d);
            else
                exact[c] += rho * power[c] * ((double)radius * radius) / (d * d) * cos_t;
        }
        ls[i] = l;
    }
}

static ml_shading_point direct_point(float rho) {
    ml_shading_point sp;
    sp.position = v3(0, 0, 0);
    sp.normal = v3(0, 0, 1);
    sp.wo = v3(0.3f, 0.1f, 1);
    sp.material = lambert(rho);
    return sp;
}

/* Mean and standard error of the estimates; checks the mean is within 5 standard errors of
 * `exact` (plus 1e-4 relative, the f32 arithmetic). */
typedef struct running {
    double sum, sum2;
    long n;
} running;

static void running_add(running *s, double x) {
    s->sum += x;
    s->sum2 += x * x;
    s->n++;
}

/* Three channels' running sums. */
typedef struct running3 {
    running c[3];
} running3;

static void running3_add(running3 *s, ml_rgb64 e) {
    running_add(&s->c[0], e.r);
    running_add(&s->c[1], e.g);
    running_add(&s->c[2], e.b);
}

static int estimate_ok(ml_rgb64 e) {
    return e.r >= 0 && e.r == e.r && e.g >= 0 && e.g == e.g && e.b >= 0 && e.b == e.b &&
           e.r < INFINITY && e.g < INFINITY && e.b < INFINITY;
}

static int running_check(const running *s, double exact, const char *what, int line) {
    double mean = s->sum / (double)s->n;
    double var = (s->sum2 / (double)s->n - mean * mean) * (double)s->n / (double)(s->n - 1);
    double se = sqrt(var > 0 ? var : 0) / sqrt((double)s->n);
    double tol = 5 * se + 1e-4 * exact;
    if (fabs(mean - exact) > tol) {
        fprintf(stderr, "line %d: %s: mean %.6g, exact %.6g, |diff| %.3g > %.3g (n = %ld)\n", line,
                what, mean, exact, fabs(mean - exact), tol, s->n);
        g_failures++;
        return 0;
    }
    printf("unbiased %s: mean %.6g, exact %.6g, 1 se %.3g, n %ld\n", what, mean, exact, se, s->n);
    return 1;
}

/* Every channel within its tolerance (see running_check). */
static int running3_check(const running3 *s, const double exact[3], const char *what, int line) {
    int c, ok = 1;
    for (c = 0; c < 3; c++) ok &= running_check(&s->c[c], exact[c], what, line);
    return ok;
}

#define N_TECHNIQUES 10
static const char *const technique_names[N_TECHNIQUES] = {
    "uniform", "power", "tl", "tl-split", "bl", "mis-equal", "full", "tl-mis", "bl-mis",
    "tl-mis-pinf"};

static float never_hit(void *user, ml_vec3 x, ml_vec3 d) {
    (void)user;
    (void)x;
    (void)d;
    return (float)INFINITY;
}

static int32_t always_occluded(void *user, ml_vec3 x, ml_vec3 d, float t) {
    (void)x;
    (void)d;
    (void)t;
    ++*(long *)user;
    return 1;
}

/* The one call, every technique: unbiased against the closed form. */
static void scenario_direct(void) {
    ml_light ls[DIRECT_LIGHTS];
    const float rho = 0.8f;
    double exact[3];
    ml_tree *tree;
    ml_shading_point sp = direct_point(rho);
    ml_estimator *est = NULL;
    uint32_t t;
    rng r;
    ml_uniforms u = uniforms_of(&r);
    direct_scene(ls, rho, exact);
    tree = build_tree(ls, DIRECT_LIGHTS);
    r.s = 31337;
    OK(ml_estimator_create(tree, &est));
    for (t = 0; t < N_TECHNIQUES; t++) {
        running3 s;
        long k, n = (t == ML_TECHNIQUE_FULL || t == ML_TECHNIQUE_MIS_EQUAL ||
                     t == ML_TECHNIQUE_TL_SPLIT) ? 1500 : 6000;
        memset(&s, 0, sizeof s);
        OK(ml_estimator_set_point(est, &sp, t, NULL));
        for (k = 0; k < n; k++) {
            ml_rgb64 e = {-1, -1, -1};
            OK(ml_estimator_estimate(est, NULL, &u, &e));
            CHECK(estimate_ok(e));
            running3_add(&s, e);
        }
        running3_check(&s, exact, technique_names[t], __LINE__);
        /* The one call without a handle gives an estimate of the same quantity. */
        {
            ml_rgb64 e = {-1, -1, -1};
            OK(ml_direct_estimate(tree, &sp, t, NULL, NULL, &u, &e));
            CHECK(estimate_ok(e));
        }
    }
    /* Visibility callbacks: a first-surface distance of +infinity changes nothing; a shadow
     * ray that always hits leaves nothing. */
    {
        ml_visibility vis;
        running3 s;
        long k, calls = 0;
        memset(&s, 0, sizeof s);
        vis.occluded = NULL;
        vis.first_hit = never_hit;
        vis.user_data = NULL;
        for (k = 0; k < 6000; k++) {
            ml_rgb64 e = {-1, -1, -1};
            OK(ml_direct_estimate(tree, &sp, ML_TECHNIQUE_DEFAULT, NULL, &vis, &u, &e));
            running3_add(&s, e);
        }
        running3_check(&s, exact, "bl-mis with first_hit", __LINE__);
        vis.occluded = always_occluded;
        vis.first_hit = NULL;
        vis.user_data = &calls;
        for (k = 0; k < 200; k++) {
            ml_rgb64 e = {-1, -1, -1};
            OK(ml_direct_estimate(tree, &sp, ML_TECHNIQUE_TL_MIS, NULL, &vis, &u, &e));
            CHECK(e.r == 0 && e.g == 0 && e.b == 0);
        }
        CHECK(calls > 0);
    }
    OK(ml_estimator_free(est));
    OK(ml_tree_free(tree));
}

/* The lower level with the host's own Lambert BSDF (cosine sampling by Malley's method), in
 * the host's own colour arithmetic: each channel times the weight's scale. */
typedef struct host_hit {
    ml_rgb64 sum;
    float f;
    float cos_theta;
} host_hit;

static void add_scaled(ml_rgb64 *sum, ml_rgb radiance, double k) {
    sum->r += radiance.r * k;
    sum->g += radiance.g * k;
    sum->b += radiance.b * k;
}

static void on_hit(void *user, const ml_light_hit *hit) {
    host_hit *h = (host_hit *)user;
    add_scaled(&h->sum, hit->point.radiance, (double)h->f * h->cos_theta * hit->weighted.scale);
}

static ml_rgb64 host_estimate(ml_estimator *est, ml_uniforms *u, float rho, int *steps) {
    ml_rgb64 sum = {0, 0, 0};
    float f = rho / (float)ML_PI;
    OK(ml_estimator_start(est));
    for (;;) {
        ml_step s;
        if (ml_estimator_next(est, u, &s) != ML_OK) {
            g_failures++;
            fprintf(stderr, "ml_estimator_next: %s\n", ml_last_error_message());
            break;
        }
        ++*steps;
        if (s.kind == ML_STEP_KIND_DONE) break;
        if (s.kind == ML_STEP_KIND_LIGHT) {
            float c = s.point.direction.z;
            ml_weighted w;
            if (c <= 0) continue;
            OK(ml_estimator_weigh(est, s.needs_bsdf_pdf ? c / (float)ML_PI : 0, &w));
            CHECK(w.weight >= 0 && w.weight <= 1 && w.scale >= 0);
            add_scaled(&sum, s.point.radiance, (double)f * c * w.scale);
        } else {
            float r = sqrtf(s.u0), phi = 2 * (float)ML_PI * s.u1;
            float z = sqrtf(1 - s.u0 > 0 ? 1 - s.u0 : 0);
            ml_vec3 wi = v3(r * cosf(phi), r * sinf(phi), z);
            host_hit h;
            uint32_t any = 7;
            if (z <= 0) continue;
            h.sum.r = h.sum.g = h.sum.b = 0;
            h.f = f;
            h.cos_theta = z;
            OK(ml_estimator_bsdf_hits(est, wi, z / (float)ML_PI, (float)INFINITY, on_hit, &h,
                                      &any));
            CHECK(any == 0 || any == 1);
            sum.r += h.sum.r;
            sum.g += h.sum.g;
            sum.b += h.sum.b;
        }
    }
    return sum;
}

static void scenario_lower_level(void) {
    ml_light ls[DIRECT_LIGHTS];
    const float rho = 0.6f;
    double exact[3];
    ml_tree *tree;
    ml_shading_point sp = direct_point(rho);
    ml_estimator *est = NULL;
    uint32_t t;
    rng r;
    ml_uniforms u = uniforms_of(&r);
    direct_scene(ls, rho, exact);
    tree = build_tree(ls, DIRECT_LIGHTS);
    r.s = 2718;
    OK(ml_estimator_create(tree, &est));
    /* The tree may go first: the estimator keeps what it needs. */
    OK(ml_tree_free(tree));
    for (t = 0; t < N_TECHNIQUES; t++) {
        running3 s;
        long k, n = (t == ML_TECHNIQUE_FULL || t == ML_TECHNIQUE_MIS_EQUAL ||
                     t == ML_TECHNIQUE_TL_SPLIT) ? 1500 : 6000;
        int steps = 0;
        memset(&s, 0, sizeof s);
        OK(ml_estimator_set_point(est, &sp, t, NULL));
        for (k = 0; k < n; k++) running3_add(&s, host_estimate(est, &u, rho, &steps));
        CHECK(steps >= n);
        running3_check(&s, exact, technique_names[t], __LINE__);
    }
    OK(ml_estimator_free(est));
}

/* ---- batches for wavefront hosts --------------------------------------------------------- */

#define WAVE_POINTS 40
#define WAVE_PER_POINT 3

static void scenario_wavefront(void) {
    ml_light ls[DIRECT_LIGHTS];
    ml_tree *tree;
    ml_shading_point sps[WAVE_POINTS];
    ml_rgb64 batch[WAVE_POINTS * WAVE_PER_POINT], single;
    double exact[3];
    uint32_t which[300];
    ml_vec3 xs[300];
    float u0s[300], u1s[300];
    ml_light_point pts[300];
    ml_estimator *est = NULL;
    rng r, ra, rb;
    ml_uniforms ua = uniforms_of(&ra), ub = uniforms_of(&rb);
    uint32_t t;
    int i, j;
    direct_scene(ls, 0.5f, exact);
    tree = build_tree(ls, DIRECT_LIGHTS);
    r.s = 77;
    for (i = 0; i < WAVE_POINTS; i++) {
        sps[i] = make_sp(&r);
        sps[i].position = v3(rng_range(&r, -1, 1), rng_range(&r, -1, 1), 0);
    }
    OK(ml_estimator_create(tree, &est));
    for (t = 0; t < 9; t++) {
        /* The batch is the per-point set-up and its estimates, one point after the other. */
        ra.s = rb.s = 1000 + t;
        OK(ml_direct_estimate_batch(tree, sps, WAVE_POINTS, WAVE_PER_POINT, t, NULL, NULL, &ua,
                                    batch));
        for (i = 0; i < WAVE_POINTS; i++) {
            OK(ml_estimator_set_point(est, &sps[i], t, NULL));
            if (i % 3 == 1) {
                /* Refused: the estimator keeps the point it was set up for. */
                ml_shading_point bad = sps[i];
                bad.normal.z = (float)NAN;
                CHECK(ml_estimator_set_point(est, &bad, t, NULL) == ML_ERR_INVALID_ARGUMENT);
            }
            for (j = 0; j < WAVE_PER_POINT; j++) {
                single.r = single.g = single.b = -1;
                OK(ml_estimator_estimate(est, NULL, &ub, &single));
                CHECK(memcmp(&single, &batch[i * WAVE_PER_POINT + j], sizeof single) == 0);
            }
        }
        CHECK(ra.s == rb.s);
        /* One estimate a point: ml_direct_estimate's. */
        ra.s = rb.s = 2000 + t;
        OK(ml_direct_estimate_batch(tree, sps, WAVE_POINTS, 1, t, NULL, NULL, &ua, batch));
        for (i = 0; i < WAVE_POINTS; i++) {
            single.r = single.g = single.b = -1;
            OK(ml_direct_estimate(tree, &sps[i], t, NULL, NULL, &ub, &single));
            CHECK(memcmp(&single, &batch[i], sizeof single) == 0);
        }
    }
    OK(ml_estimator_free(est));
    /* Points on lights for many (light, x, u) triples. */
    for (i = 0; i < 300; i++) {
        which[i] = (uint32_t)(rng_next(&r) % DIRECT_LIGHTS);
        xs[i] = v3(rng_range(&r, -2, 2), rng_range(&r, -2, 2), 0);
        u0s[i] = rng_f32(&r);
        u1s[i] = rng_f32(&r);
    }
    OK(ml_light_sample_point_batch(tree, which, xs, u0s, u1s, 300, pts));
    for (i = 0; i < 300; i++) {
        ml_light_point p;
        OK(ml_light_sample_point(tree, which[i], xs[i], u0s[i], u1s[i], &p));
        CHECK(memcmp(&p, &pts[i], sizeof p) == 0);
    }
    OK(ml_light_sample_point_batch(tree, NULL, NULL, NULL, NULL, 0, NULL));
    OK(ml_tree_free(tree));
}

/* ---- a sun and a host environment ------------------------------------------------------ */

/* The host's uniform environment of radiance SKY_L, sampled uniformly over the sphere. */
static const float SKY_L[3] = {0.2f, 0.3f, 0.45f};

/* The environment's user data: its calls, and the radiance its callbacks give (SKY_L, or a
 * bad value for the checks of bad values). */
typedef struct sky_host {
    long calls;
    ml_rgb sample_radiance;
    ml_rgb eval_radiance;
} sky_host;

static void sky_host_init(sky_host *h) {
    h->calls = 0;
    h->sample_radiance = rgb(SKY_L[0], SKY_L[1], SKY_L[2]);
    h->eval_radiance = h->sample_radiance;
}

static ml_vec3 sky_direction(float u0, float u1) {
    float z = 1 - 2 * u0, r = sqrtf(1 - z * z > 0 ? 1 - z * z : 0), phi = 2 * (float)ML_PI * u1;
    return v3(r * cosf(phi), r * sinf(phi), z);
}

static int32_t sky_sample(void *user, float u0, float u1, ml_vec3 *d, ml_rgb *radiance,
                          float *pdf) {
    sky_host *h = (sky_host *)user;
    ++h->calls;
    *d = sky_direction(u0, u1);
    *radiance = h->sample_radiance;
    *pdf = 1 / (4 * (float)ML_PI);
    return 1;
}

static void sky_eval(void *user, ml_vec3 d, ml_rgb *radiance, float *pdf) {
    sky_host *h = (sky_host *)user;
    (void)d;
    ++h->calls;
    *radiance = h->eval_radiance;
    *pdf = 1 / (4 * (float)ML_PI);
}

/* The environment of the host `h`, with bounds π Y(L) (a hair above). */
static ml_environment sky_environment(sky_host *h) {
    ml_environment env;
    double y = ML_PI * (0.2126 * SKY_L[0] + 0.7152 * SKY_L[1] + 0.0722 * SKY_L[2]) * 1.0001;
    int c;
    memset(&env, 0, sizeof env);
    env.sample = sky_sample;
    env.eval = sky_eval;
    env.user_data = h;
    for (c = 0; c < 6; c++) env.irradiance_bounds[c] = (float)y;
    return env;
}

/* The lights of a tree with the sun; the environment given at the build is light
 * INFINITE_LIGHTS, one past them. */
#define INFINITE_LIGHTS (DIRECT_LIGHTS + 1)
#define SKY_INDEX INFINITE_LIGHTS

/* direct_scene's lights and a sun of irradiance E (its cap entirely above the horizon, at θ
 * from the normal: it reflects ρ/π · E cos θ); with the uniform sky (given at the build) the
 * point reflects ρ L more. */
static void infinite_scene(ml_light *ls, float rho, double exact[3]) {
    ml_light sun;
    const float e[3] = {1.5f, 1.1f, 0.7f};
    double len, cos_t;
    int c;
    direct_scene(ls, rho, exact);
    memset(&sun, 0, sizeof sun);
    sun.distant.kind = ML_LIGHT_KIND_DISTANT;
    sun.distant.direction = v3(0.4f, -0.3f, 1);
    sun.distant.angular_radius = 0.05f;
    sun.distant.irradiance = rgb(e[0], e[1], e[2]);
    len = sqrt(0.16 + 0.09 + 1.0);
    cos_t = 1.0 / len;
    for (c = 0; c < 3; c++) exact[c] += rho / ML_PI * e[c] * cos_t + rho * SKY_L[c];
    ls[DIRECT_LIGHTS] = sun;
}

/* The radiance is SKY_L, bit for bit. */
static int is_sky(ml_rgb l) { return l.r == SKY_L[0] && l.g == SKY_L[1] && l.b == SKY_L[2]; }

/* The sky's hits carry its radiance (from eval) and pdf, at infinity. */
static void on_hit_sky(void *user, const ml_light_hit *hit) {
    host_hit *h = (host_hit *)user;
    if (hit->light == SKY_INDEX) {
        CHECK(is_sky(hit->point.radiance) && hit->point.distance == (float)INFINITY &&
              hit->point.pdf == 1 / (4 * (float)ML_PI));
    }
    add_scaled(&h->sum, hit->point.radiance, (double)h->f * h->cos_theta * hit->weighted.scale);
}

/* host_estimate on a tree with the environment: its samples come as light steps at infinity,
 * escaping rays reach it. */
static ml_rgb64 host_estimate_env(ml_estimator *est, ml_uniforms *u, float rho, long *env_steps,
                                  long *env_hits) {
    ml_rgb64 sum = {0, 0, 0};
    float f = rho / (float)ML_PI;
    OK(ml_estimator_start(est));
    for (;;) {
        ml_step s;
        if (ml_estimator_next(est, u, &s) != ML_OK) {
            g_failures++;
            fprintf(stderr, "ml_estimator_next: %s\n", ml_last_error_message());
            break;
        }
        if (s.kind == ML_STEP_KIND_DONE) break;
        if (s.kind == ML_STEP_KIND_LIGHT) {
            float c = s.point.direction.z;
            ml_weighted w;
            if (s.light == SKY_INDEX) {
                ++*env_steps;
                CHECK(s.point.distance == (float)INFINITY && is_sky(s.point.radiance) &&
                      s.point.pdf == 1 / (4 * (float)ML_PI));
            }
            if (c <= 0) continue;
            OK(ml_estimator_weigh(est, s.needs_bsdf_pdf ? c / (float)ML_PI : 0, &w));
            CHECK(w.weight >= 0 && w.weight <= 1 && w.scale >= 0);
            add_scaled(&sum, s.point.radiance, (double)f * c * w.scale);
        } else {
            float r = sqrtf(s.u0), phi = 2 * (float)ML_PI * s.u1;
            float z = sqrtf(1 - s.u0 > 0 ? 1 - s.u0 : 0);
            ml_vec3 wi = v3(r * cosf(phi), r * sinf(phi), z);
            host_hit h;
            uint32_t any = 7;
            if (z <= 0) continue;
            h.sum.r = h.sum.g = h.sum.b = 0;
            h.f = f;
            h.cos_theta = z;
            OK(ml_estimator_bsdf_hits(est, wi, z / (float)ML_PI, (float)INFINITY, on_hit_sky, &h,
                                      &any));
            /* An escaping ray always reaches the environment. */
            CHECK(any == 1);
            ++*env_hits;
            sum.r += h.sum.r;
            sum.g += h.sum.g;
            sum.b += h.sum.b;
        }
    }
    return sum;
}

/* The lights of direct_scene with a sun and a host sky given at the build, in colour: every
 * technique through the one call and through the step loop, against the closed form. */
static void scenario_infinite(void) {
    ml_light ls[INFINITE_LIGHTS];
    const float rho = 0.7f;
    double exact[3];
    ml_tree *tree = NULL;
    ml_shading_point sp = direct_point(rho);
    ml_estimator *est = NULL;
    ml_environment env;
    sky_host host;
    uint32_t t;
    long env_steps = 0, env_hits = 0;
    rng r;
    ml_uniforms u = uniforms_of(&r);
    ml_tree_statistics st;
    infinite_scene(ls, rho, exact);
    sky_host_init(&host);
    env = sky_environment(&host);
    OK(ml_tree_build(ls, INFINITE_LIGHTS, &env, NULL, &tree));
    /* The tree copied the struct: the caller's copy may go. */
    memset(&env, 0, sizeof env);
    OK(ml_tree_stats(tree, &st));
    CHECK(st.lights == INFINITE_LIGHTS + 1);
    r.s = 8080;
    OK(ml_estimator_create(tree, &est));
    for (t = 0; t < N_TECHNIQUES; t++) {
        running3 s, s2;
        long k, n = (t == ML_TECHNIQUE_FULL || t == ML_TECHNIQUE_MIS_EQUAL ||
                     t == ML_TECHNIQUE_TL_SPLIT) ? 1500 : 6000;
        memset(&s, 0, sizeof s);
        memset(&s2, 0, sizeof s2);
        OK(ml_estimator_set_point(est, &sp, t, NULL));
        for (k = 0; k < n; k++) {
            ml_rgb64 e = {-1, -1, -1};
            OK(ml_estimator_estimate(est, NULL, &u, &e));
            CHECK(estimate_ok(e));
            running3_add(&s, e);
            running3_add(&s2, host_estimate_env(est, &u, rho, &env_steps, &env_hits));
        }
        running3_check(&s, exact, technique_names[t], __LINE__);
        running3_check(&s2, exact, technique_names[t], __LINE__);
        {
            ml_rgb64 e = {-1, -1, -1};
            OK(ml_direct_estimate(tree, &sp, t, NULL, NULL, &u, &e));
            CHECK(estimate_ok(e));
        }
    }
    CHECK(host.calls > 0 && env_steps > 0 && env_hits > 0);
    /* The tree may go first: the estimator keeps the environment. */
    OK(ml_tree_free(tree));
    {
        ml_rgb64 e = {-1, -1, -1};
        long before = host.calls;
        OK(ml_estimator_set_point(est, &sp, ML_TECHNIQUE_TL_MIS, NULL));
        OK(ml_estimator_estimate(est, NULL, &u, &e));
        CHECK(estimate_ok(e) && host.calls > before);
    }
    OK(ml_estimator_free(est));
}

/* The environment's points through ml_light_sample_point (light `count`): its sample at
 * infinity, its pdf from eval; the batch equal to the single calls. */
static void scenario_environment_points(void) {
    ml_light ls[INFINITE_LIGHTS];
    double exact[3];
    ml_tree *tree = NULL;
    ml_environment env;
    sky_host host;
    rng r;
    int i;
    uint32_t which[64];
    ml_vec3 xs[64];
    float u0s[64], u1s[64];
    ml_light_point pts[64];
    infinite_scene(ls, 0.5f, exact);
    sky_host_init(&host);
    env = sky_environment(&host);
    OK(ml_tree_build(ls, INFINITE_LIGHTS, &env, NULL, &tree));
    r.s = 5150;
    for (i = 0; i < 64; i++) {
        ml_light_point p;
        ml_vec3 x = v3(rng_range(&r, -2, 2), rng_range(&r, -2, 2), 0), d;
        float u0 = rng_f32(&r), u1 = rng_f32(&r), q = -1;
        memset(&p, 0, sizeof p);
        OK(ml_light_sample_point(tree, SKY_INDEX, x, u0, u1, &p));
        d = sky_direction(u0, u1);
        CHECK(p.pdf > 0 && p.pdf == 1 / (4 * (float)ML_PI));
        CHECK(p.distance == (float)INFINITY && is_sky(p.radiance));
        /* position = direction, the host's direction (unit up to its rounding). */
        CHECK(fabs(p.position.x - d.x) < 1e-5 && fabs(p.position.y - d.y) < 1e-5 &&
              fabs(p.position.z - d.z) < 1e-5);
        CHECK(p.position.x == p.direction.x && p.position.y == p.direction.y &&
              p.position.z == p.direction.z);
        OK(ml_light_pdf_point(tree, SKY_INDEX, x, p.position, &q));
        CHECK(q == 1 / (4 * (float)ML_PI));
        which[i] = (uint32_t)(i % 3 == 0 ? SKY_INDEX : rng_next(&r) % (INFINITE_LIGHTS + 1));
        xs[i] = x;
        u0s[i] = u0;
        u1s[i] = u1;
    }
    OK(ml_light_sample_point_batch(tree, which, xs, u0s, u1s, 64, pts));
    for (i = 0; i < 64; i++) {
        ml_light_point p;
        OK(ml_light_sample_point(tree, which[i], xs[i], u0s[i], u1s[i], &p));
        CHECK(memcmp(&p, &pts[i], sizeof p) == 0);
    }
    {
        ml_light_point p;
        BAD_VALUE(ml_light_sample_point,
                  ml_light_sample_point(tree, SKY_INDEX + 1, v3(0, 0, 0), 0.5f, 0.5f, &p),
                  ML_ERR_INVALID_ARGUMENT, "light");
    }
    OK(ml_tree_free(tree));
}

/* The wavefront batch on a tree with only a uniform environment of radiance L over a Lambert
 * plane of albedo ρ (the whole upper hemisphere unoccluded): every technique's mean is ρ·L
 * within 5 standard errors of the sample mean. */
#define ENV_POINTS 40
#define ENV_PER_POINT 50

static void scenario_environment_batch(void) {
    const float rho = 0.6f;
    double exact[3];
    ml_tree *tree = NULL;
    ml_environment env;
    sky_host host;
    ml_shading_point sps[ENV_POINTS];
    static ml_rgb64 out[ENV_POINTS * ENV_PER_POINT];
    rng r;
    ml_uniforms u = uniforms_of(&r);
    uint32_t t;
    int i, c;
    sky_host_init(&host);
    env = sky_environment(&host);
    OK(ml_tree_build(NULL, 0, &env, NULL, &tree));
    for (c = 0; c < 3; c++) exact[c] = rho * SKY_L[c];
    r.s = 6060;
    for (i = 0; i < ENV_POINTS; i++) {
        sps[i] = direct_point(rho);
        sps[i].position = v3(rng_range(&r, -5, 5), rng_range(&r, -5, 5), 0);
        sps[i].wo = v3(rng_range(&r, -1, 1), rng_range(&r, -1, 1), 1);
    }
    for (t = 0; t < N_TECHNIQUES; t++) {
        running3 s;
        char what[64];
        memset(&s, 0, sizeof s);
        OK(ml_direct_estimate_batch(tree, sps, ENV_POINTS, ENV_PER_POINT, t, NULL, NULL, &u, out));
        for (i = 0; i < ENV_POINTS * ENV_PER_POINT; i++) {
            CHECK(estimate_ok(out[i]));
            running3_add(&s, out[i]);
        }
        snprintf(what, sizeof what, "batch on an environment, %s", technique_names[t]);
        running3_check(&s, exact, what, __LINE__);
    }
    OK(ml_tree_free(tree));
}

/* Bad input to the calls of the environment, and bad values from its callbacks. */
static void bad_input_infinite(void) {
    ml_light ls[INFINITE_LIGHTS], seven[4];
    double exact[3];
    ml_tree *tree = NULL, *t2 = NULL;
    ml_shading_point sp = direct_point(0.5f);
    ml_estimator *est = NULL;
    ml_environment env, bad;
    sky_host host;
    ml_rgb64 e = {0, 0, 0};
    ml_rgb64 batch[4];
    unsigned char *bytes;
    size_t sz = 0, written = 0;
    int i, k;
    rng r;
    ml_uniforms u = uniforms_of(&r);
    const float bad_values[3] = {(float)NAN, -1.0f, (float)INFINITY};
    r.s = 99;
    infinite_scene(ls, 0.5f, exact);
    sky_host_init(&host);
    env = sky_environment(&host);
    /* The environment's callbacks and bounds at the build. */
    bad = env;
    bad.sample = NULL;
    BAD_NULL(ml_tree_build, ml_tree_build(ls, INFINITE_LIGHTS, &bad, NULL, &t2),
             "environment->sample");
    CHECK(t2 == NULL);
    bad = env;
    bad.eval = NULL;
    BAD_NULL(ml_tree_build_parallel, ml_tree_build_parallel(ls, INFINITE_LIGHTS, &bad, NULL, 2, &t2),
             "environment->eval");
    CHECK(t2 == NULL);
    bad = env;
    bad.irradiance_bounds[3] = -1;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, INFINITE_LIGHTS, &bad, NULL, &t2),
              ML_ERR_INVALID_ARGUMENT, "environment->irradiance_bounds");
    bad.irradiance_bounds[3] = (float)NAN;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, INFINITE_LIGHTS, &bad, NULL, &t2),
              ML_ERR_INVALID_ARGUMENT, "environment->irradiance_bounds");
    bad.irradiance_bounds[3] = 1e30f;
    BAD_VALUE(ml_tree_build_parallel,
              ml_tree_build_parallel(ls, INFINITE_LIGHTS, &bad, NULL, 2, &t2),
              ML_ERR_INVALID_ARGUMENT, "environment->irradiance_bounds");
    CHECK(t2 == NULL);
    /* Kind 7, the former environment light, is no light kind. */
    memcpy(seven, ls, sizeof seven);
    seven[3].kind = 7;
    BAD_VALUE(ml_tree_build, ml_tree_build(seven, 4, NULL, NULL, &t2), ML_ERR_INVALID_ARGUMENT,
              "lights[3].kind");
    BAD_VALUE(ml_tree_build, ml_tree_build(seven, 4, &env, NULL, &t2), ML_ERR_INVALID_ARGUMENT,
              "lights[3].kind");
    CHECK(t2 == NULL);
    /* A tree with an environment, cached and loaded with its lights and environment. */
    OK(ml_tree_build(ls, INFINITE_LIGHTS, &env, NULL, &tree));
    OK(ml_tree_serialized_size(tree, &sz));
    bytes = (unsigned char *)malloc(sz);
    OK(ml_tree_serialize(tree, bytes, sz, &written));
    bad = env;
    bad.eval = NULL;
    BAD_NULL(ml_tree_load_with_lights,
             ml_tree_load_with_lights(bytes, sz, ls, INFINITE_LIGHTS, &bad, &t2),
             "environment->eval");
    CHECK(t2 == NULL);
    OK(ml_tree_load_with_lights(bytes, sz, ls, INFINITE_LIGHTS, &env, &t2));
    {
        ml_light_point a, b;
        OK(ml_light_sample_point(tree, SKY_INDEX, v3(0, 0, 0), 0.3f, 0.6f, &a));
        OK(ml_light_sample_point(t2, SKY_INDEX, v3(0, 0, 0), 0.3f, 0.6f, &b));
        CHECK(memcmp(&a, &b, sizeof a) == 0 && a.pdf > 0);
    }
    OK(ml_tree_free(t2));
    t2 = NULL;
    free(bytes);
    /* Bad values from the callbacks: an environment whose eval returns a NaN, negative or
     * infinite radiance makes the estimates whose BSDF ray escapes (tl-mis at an unoccluded
     * point: every BSDF ray escapes) ML_ERR_INVALID_ARGUMENT, naming the environment. */
    OK(ml_estimator_create(tree, &est));
    OK(ml_estimator_set_point(est, &sp, ML_TECHNIQUE_TL_MIS, NULL));
    for (i = 0; i < 3; i++) {
        sky_host_init(&host);
        host.eval_radiance = rgb(0.2f, bad_values[i], 0.4f);
        for (k = 0; k < 20; k++) {
            BAD_VALUE(ml_direct_estimate,
                      ml_direct_estimate(tree, &sp, ML_TECHNIQUE_TL_MIS, NULL, NULL, &u, &e),
                      ML_ERR_INVALID_ARGUMENT, "environment");
            BAD_VALUE(ml_estimator_estimate, ml_estimator_estimate(est, NULL, &u, &e),
                      ML_ERR_INVALID_ARGUMENT, "environment");
        }
        BAD_VALUE(ml_direct_estimate_batch,
                  ml_direct_estimate_batch(tree, &sp, 1, 4, ML_TECHNIQUE_TL_MIS, NULL, NULL, &u,
                                           batch),
                  ML_ERR_INVALID_ARGUMENT, "environment");
        /* And from sample: a point on the environment is refused. */
        host.sample_radiance = host.eval_radiance;
        {
            ml_light_point p;
            BAD_VALUE(ml_light_sample_point,
                      ml_light_sample_point(tree, SKY_INDEX, v3(0, 0, 0), 0.5f, 0.5f, &p),
                      ML_ERR_INVALID_ARGUMENT, "environment");
        }
        {
            float q;
            BAD_VALUE(ml_light_pdf_point,
                      ml_light_pdf_point(tree, SKY_INDEX, v3(0, 0, 0), v3(0, 0, 1), &q),
                      ML_ERR_INVALID_ARGUMENT, "environment");
        }
    }
    sky_host_init(&host);
    OK(ml_estimator_estimate(est, NULL, &u, &e));
    CHECK(estimate_ok(e));
    OK(ml_estimator_free(est));
    OK(ml_tree_free(tree));
}

/* ---- VPL acceptance -------------------------------------------------------------------- */

static int32_t count_visible(void *user, ml_vec3 importon, ml_vec3 vpl) {
    (void)importon;
    (void)vpl;
    ++*(long *)user;
    return 1;
}

static void scenario_vpl(void) {
    ml_acceptor_options o;
    ml_acceptor *acc = NULL;
    ml_importon imps[100];
    ml_accept_stats st;
    ml_vpl_visibility vis;
    ml_light *accepted = (ml_light *)malloc(3000 * sizeof(ml_light));
    size_t n_acc = 0;
    long calls = 0;
    rng r;
    int i;
    r.s = 8080;
    OK(ml_acceptor_options_default(&o));
    o.pixels = 64 * 64;
    o.wanted = 100;
    OK(ml_acceptor_create(&o, &acc));
    memset(imps, 0, sizeof imps);
    for (i = 0; i < 100; i++) {
        imps[i].hit = i % 10 == 9 ? 0 : 1;
        imps[i].position = v3(rng_range(&r, -2, 2), rng_range(&r, -2, 2), 0);
        imps[i].normal = v3(0, 0, 1);
        imps[i].wo = v3(0, 0.2f, 1);
        imps[i].material = i % 7 == 3 ? plastic(0.4f, 0.5f, 0.3f) : lambert(0.5f);
    }
    OK(ml_acceptor_set_importons(acc, imps, 100));
    /* First frame: Φ̃_total = 0, every candidate is kept unchanged. */
    for (i = 0; i < 20; i++) {
        ml_vpl c;
        ml_vpl_decision d;
        c.position = v3(rng_range(&r, -3, 3), rng_range(&r, -3, 3), rng_range(&r, 0.5f, 3));
        c.normal = v3(0, 0, -1);
        c.intensity = grey(1.5f);
        OK(ml_acceptor_accept(acc, &c, rng_f32(&r), NULL, &d));
        CHECK(d.accepted == 1 && d.probability == 1 && d.vpl.intensity.r == 1.5f && d.vpl.intensity.b == 1.5f);
    }
    OK(ml_acceptor_reset_stats(acc));
    OK(ml_acceptor_set_total_luminance(acc, 4e4));
    OK(ml_acceptor_update(acc, 4e4));
    vis.visible = count_visible;
    vis.user_data = &calls;
    for (i = 0; i < 3000; i++) {
        ml_vpl c;
        ml_vpl_decision d;
        float p0 = -1, p1 = -1;
        c.position = v3(rng_range(&r, -6, 6), rng_range(&r, -6, 6), rng_range(&r, 0.3f, 4));
        c.normal = v3(rng_range(&r, -0.5f, 0.5f), rng_range(&r, -0.5f, 0.5f), -1);
        c.intensity = rgb(rng_range(&r, 0.5f, 2), rng_range(&r, 0.5f, 2), rng_range(&r, 0.5f, 2));
        if (i % 50 == 0) {
            OK(ml_acceptor_probability(acc, &c, NULL, &p0));
            OK(ml_acceptor_probability(acc, &c, &vis, &p1));
            CHECK(p0 > 0 && p0 <= 1 && p0 == p1);
        }
        OK(ml_acceptor_accept(acc, &c, rng_f32(&r), i % 2 ? &vis : NULL, &d));
        if (d.accepted) {
            CHECK(d.probability > 0 && d.probability <= 1);
            CHECK(fabs(d.vpl.intensity.g - c.intensity.g / d.probability) <= 1e-5 * d.vpl.intensity.g);
            memset(&accepted[n_acc], 0, sizeof accepted[n_acc]);
            accepted[n_acc].vpl.kind = ML_LIGHT_KIND_VPL;
            accepted[n_acc].vpl.position = d.vpl.position;
            accepted[n_acc].vpl.normal = d.vpl.normal;
            accepted[n_acc].vpl.intensity = d.vpl.intensity;
            n_acc++;
        }
    }
    CHECK(calls > 0);
    OK(ml_acceptor_stats(acc, &st));
    CHECK(st.candidates == 3000 && st.accepted == n_acc);
    CHECK(st.acceptance_rate > 0.01 && st.acceptance_rate < 0.99);
    /* Unbiased: the accepted energy's ratio to the candidates' is 1 within 5 sd. */
    CHECK(fabs(st.energy_ratio - 1) <= 5 * st.energy_ratio_sd + 1e-9);
    OK(ml_acceptor_reset_stats(acc));
    OK(ml_acceptor_stats(acc, &st));
    CHECK(st.candidates == 0 && st.accepted == 0);
    /* The accepted VPLs are lights of a tree. */
    {
        ml_tree *tree = build_tree(accepted, n_acc);
        ml_tl_point p;
        ml_sampled_light s;
        float q = -1;
        p.position = v3(0, 0, 0);
        p.normal = v3(0, 0, 1);
        p.receiver = ML_RECEIVER_REFLECTIVE;
        OK(ml_tree_sample_tl(tree, &p, 0.5f, &s));
        CHECK(s.light != ML_NO_LIGHT);
        if (s.light != ML_NO_LIGHT) {
            OK(ml_tree_pmf_tl(tree, &p, s.light, &q));
            CHECK(bits(q) == bits(s.pmf));
        }
        OK(ml_tree_free(tree));
    }
    OK(ml_acceptor_free(acc));
    free(accepted);
}

/* ---- bad input: every function, NULL and an invalid value ------------------------------ */

static float bad_uniform(void *user) {
    (void)user;
    return 1.5f;
}

static float nan_hit(void *user, ml_vec3 x, ml_vec3 d) {
    (void)user;
    (void)x;
    (void)d;
    return (float)NAN;
}

/* The serialized bytes of `tree` (malloc'd), their number in *size. */
static uint8_t *tree_bytes(const ml_tree *tree, size_t *size) {
    size_t written = 0;
    uint8_t *buf;
    *size = 0;
    OK(ml_tree_serialized_size(tree, size));
    buf = (uint8_t *)malloc(*size);
    OK(ml_tree_serialize(tree, buf, *size, &written));
    CHECK(written == *size);
    return buf;
}

/* ml_tree_build_parallel gives ml_tree_build's tree, byte for byte, at a size whose build is
   split (20000 lights), with 2 threads and with one per core. */
static void scenario_parallel_build(void) {
    const size_t n = 20000;
    ml_light *lights = make_lights(n, 77);
    ml_tree *serial = NULL, *one = NULL, *two = NULL, *all = NULL;
    size_t ns = 0, n1 = 0, n2 = 0, na = 0;
    uint8_t *bs, *b1, *b2, *ba;
    OK(ml_tree_build(lights, n, NULL, NULL, &serial));
    OK(ml_tree_build_parallel(lights, n, NULL, NULL, 1, &one));
    OK(ml_tree_build_parallel(lights, n, NULL, NULL, 2, &two));
    OK(ml_tree_build_parallel(lights, n, NULL, NULL, 0, &all));
    if (serial != NULL && one != NULL && two != NULL && all != NULL) {
        bs = tree_bytes(serial, &ns);
        b1 = tree_bytes(one, &n1);
        b2 = tree_bytes(two, &n2);
        ba = tree_bytes(all, &na);
        CHECK(ns > 0 && ns == n1 && ns == n2 && ns == na);
        CHECK(ns == n1 && memcmp(bs, b1, ns) == 0);
        CHECK(ns == n2 && memcmp(bs, b2, ns) == 0);
        CHECK(ns == na && memcmp(bs, ba, ns) == 0);
        free(bs);
        free(b1);
        free(b2);
        free(ba);
    }
    OK(ml_tree_free(serial));
    OK(ml_tree_free(one));
    OK(ml_tree_free(two));
    OK(ml_tree_free(all));
    free(lights);
}

static void scenario_bad_input(const ml_tree *tree, size_t n) {
    ml_light ls[4];
    ml_tree *t = NULL, *loaded = NULL, *t2 = NULL;
    ml_tl_point p, pts[8];
    ml_shading_point sp, sps[8];
    ml_sampled_light s, outs[8];
    float us[8], f = 0, q = 0;
    ml_rgb fc = {0, 0, 0};
    uint32_t lights[8], u32s[4];
    size_t sz = 0, written = 0;
    uint8_t buf[64], *bytes;
    ml_tree_statistics st;
    ml_build_options bo;
    ml_bl_cut_options co;
    ml_split_cut_options so;
    ml_direct_params dp;
    ml_acceptor_options ao;
    ml_cut *cut = NULL, *fresh = NULL;
    ml_estimator *est = NULL;
    ml_acceptor *acc = NULL;
    ml_light_point lp, lps[4];
    ml_vec3 xs4[4];
    ml_brdf_draw bd;
    ml_step step;
    ml_weighted w;
    ml_visibility vis;
    ml_vpl_visibility vvis;
    ml_vpl cand;
    ml_vpl_decision dec;
    ml_importon imps[4];
    ml_accept_stats ast;
    const char *name = NULL;
    ml_rgb64 e = {0, 0, 0};
    ml_rgb64 dbl[2];
    rng r;
    ml_uniforms u = uniforms_of(&r), badu = uniforms_of(&r), nullu = uniforms_of(&r);
    int i;
    r.s = 1;
    badu.next_f32 = bad_uniform;
    badu.next_f64 = NULL;
    nullu.next_f32 = NULL;

    /* version, status names, option defaults */
    BAD_NULL(ml_version, ml_version(NULL, &u32s[0], &u32s[1]), "`major` is NULL");
    BAD_VALUE(ml_version, ml_version(&u32s[0], MISALIGN(uint32_t, &u32s[1]), &u32s[2]),
              ML_ERR_INVALID_ARGUMENT, "`minor` is misaligned");
    OK(ml_version(&u32s[0], &u32s[1], &u32s[2]));
    CHECK(u32s[0] == ML_VERSION_MAJOR && u32s[1] == ML_VERSION_MINOR && u32s[2] == ML_VERSION_PATCH);
    BAD_NULL(ml_status_name, ml_status_name(ML_OK, NULL), "`out` is NULL");
    BAD_VALUE(ml_status_name, ml_status_name(ML_OK, MISALIGN(const char *, dbl)),
              ML_ERR_INVALID_ARGUMENT, "misaligned");
    OK(ml_status_name(ML_ERR_FORMAT, &name));
    CHECK(name != NULL && strcmp(name, "ML_ERR_FORMAT") == 0);
    OK(ml_status_name(99, &name));
    CHECK(name != NULL && strcmp(name, "unknown") == 0);
    BAD_NULL(ml_build_options_default, ml_build_options_default(NULL), "`out`");
    BAD_VALUE(ml_build_options_default, ml_build_options_default(MISALIGN(ml_build_options, dbl)),
              ML_ERR_INVALID_ARGUMENT, "misaligned");
    BAD_NULL(ml_bl_cut_options_default, ml_bl_cut_options_default(NULL), "`out`");
    BAD_VALUE(ml_bl_cut_options_default, ml_bl_cut_options_default(MISALIGN(ml_bl_cut_options, dbl)),
              ML_ERR_INVALID_ARGUMENT, "misaligned");
    BAD_NULL(ml_split_cut_options_default, ml_split_cut_options_default(NULL), "`out`");
    BAD_VALUE(ml_split_cut_options_default, ml_split_cut_options_default(MISALIGN(ml_split_cut_options, dbl)),
              ML_ERR_INVALID_ARGUMENT, "misaligned");
    BAD_NULL(ml_direct_params_default, ml_direct_params_default(NULL), "`out`");
    BAD_VALUE(ml_direct_params_default, ml_direct_params_default(MISALIGN(ml_direct_params, &dp)),
              ML_ERR_INVALID_ARGUMENT, "misaligned");
    BAD_NULL(ml_acceptor_options_default, ml_acceptor_options_default(NULL), "`out`");
    BAD_VALUE(ml_acceptor_options_default,
              ml_acceptor_options_default(MISALIGN(ml_acceptor_options, &ao)),
              ML_ERR_INVALID_ARGUMENT, "misaligned");

    /* tree build: every kind of bad light */
    memset(ls, 0, sizeof ls);
    for (i = 0; i < 4; i++) {
        ls[i].sphere.kind = ML_LIGHT_KIND_SPHERE;
        ls[i].sphere.center = v3((float)i, 0, 2);
        ls[i].sphere.radius = 0.1f;
        ls[i].sphere.radiance = grey(1);
    }
    BAD_NULL(ml_tree_build, ml_tree_build(NULL, 3, NULL, NULL, &t), "`lights` is NULL");
    BAD_NULL(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, NULL), "`out` is NULL");
    ls[1].sphere.center.y = (float)NAN;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, &t), ML_ERR_INVALID_ARGUMENT,
              "lights[1].sphere.center is NaN or infinite");
    ls[1].sphere.center.y = 0;
    ls[2].sphere.radiance = rgb(1, -1, 1);
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, &t), ML_ERR_INVALID_ARGUMENT,
              "lights[2].sphere.radiance is negative (got -1)");
    ls[2].sphere.radiance = grey(1);
    ls[3].sphere.radius = -1;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, &t), ML_ERR_INVALID_ARGUMENT,
              "lights[3].sphere.radius must be positive (got -1)");
    ls[3].sphere.radius = 0.1f;
    ls[0].kind = 9;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, &t), ML_ERR_INVALID_ARGUMENT,
              "lights[0].kind: 9 is not an ml_light_kind");
    memset(&ls[0], 0, sizeof ls[0]);
    ls[0].disk.kind = ML_LIGHT_KIND_DISK;
    ls[0].disk.center = v3(0, 0, 2);
    ls[0].disk.normal = v3(0, 0, -1);
    ls[0].disk.radius = 0.1f;
    ls[0].disk.radiance = grey(1);
    ls[0].disk.two_sided = 2;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, &t), ML_ERR_INVALID_ARGUMENT,
              "lights[0].disk.two_sided must be 0 or 1");
    ls[0].disk.two_sided = 0;
    ls[0].disk.normal = v3(0, 0, 0);
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, &t), ML_ERR_INVALID_ARGUMENT,
              "lights[0].disk.normal has zero length");
    memset(&ls[0], 0, sizeof ls[0]);
    ls[0].spot.kind = ML_LIGHT_KIND_SPOT;
    ls[0].spot.position = v3(0, 0, 2);
    ls[0].spot.axis = v3(0, 0, -1);
    ls[0].spot.intensity = grey(1);
    ls[0].spot.half_angle = 4;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, &t), ML_ERR_INVALID_ARGUMENT,
              "lights[0].spot.half_angle must be in (0, pi] (got 4)");
    ls[0].spot.half_angle = 0.5f;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, (size_t)-1, NULL, NULL, &t), ML_ERR_INVALID_ARGUMENT,
              "overflow");
    bo.buckets = 5;
    BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, &bo, &t), ML_ERR_INVALID_ARGUMENT,
              "options.buckets must be 0 or in [12, 64], ML_MIN_BUCKETS to ML_MAX_BUCKETS (got 5)");
    CHECK(t == NULL); /* no output on failure */
    BAD_NULL(ml_tree_build_parallel, ml_tree_build_parallel(NULL, 3, NULL, NULL, 2, &t),
             "`lights` is NULL");
    BAD_NULL(ml_tree_build_parallel, ml_tree_build_parallel(ls, 4, NULL, NULL, 2, NULL),
             "`out` is NULL");
    BAD_VALUE(ml_tree_build_parallel, ml_tree_build_parallel(ls, 4, NULL, NULL, 5000, &t),
              ML_ERR_INVALID_ARGUMENT, "threads must be at most 1024 (got 5000)");
    ls[2].sphere.radiance = rgb(1, -1, 1);
    BAD_VALUE(ml_tree_build_parallel, ml_tree_build_parallel(ls, 4, NULL, NULL, 2, &t),
              ML_ERR_INVALID_ARGUMENT, "lights[2].sphere.radiance is negative (got -1)");
    ls[2].sphere.radiance = grey(1);
    CHECK(t == NULL);
    bo.buckets = 32;
    OK(ml_tree_build(ls, 4, NULL, &bo, &t));
    FREE_NULL(ml_tree_free, ml_tree_free(NULL));

    BAD_NULL(ml_tree_stats, ml_tree_stats(NULL, &st), "`tree` is NULL");
    BAD_VALUE(ml_tree_stats, ml_tree_stats(tree, MISALIGN(ml_tree_statistics, &st)),
              ML_ERR_INVALID_ARGUMENT, "`out` is misaligned");
    BAD_NULL(ml_tree_serialized_size, ml_tree_serialized_size(tree, NULL), "`out`");
    BAD_VALUE(ml_tree_serialized_size, ml_tree_serialized_size(MISALIGN(ml_tree, t), &sz),
              ML_ERR_INVALID_ARGUMENT, "`tree` is misaligned");
    BAD_NULL(ml_tree_serialize, ml_tree_serialize(t, NULL, 100, &written), "`buffer` is NULL");
    written = 12345;
    BAD_VALUE(ml_tree_serialize, ml_tree_serialize(t, buf, sizeof buf, &written),
              ML_ERR_BUFFER_TOO_SMALL, "capacity: 64 bytes, the tree needs");
    CHECK(written == 12345);
    OK(ml_tree_serialized_size(t, &sz));
    bytes = (uint8_t *)malloc(sz);
    OK(ml_tree_serialize(t, bytes, sz, &written));
    BAD_NULL(ml_tree_load, ml_tree_load(NULL, 10, &loaded), "`bytes` is NULL");
    BAD_NULL(ml_tree_load, ml_tree_load(bytes, sz, NULL), "`out` is NULL");
    bytes[0] ^= 1;
    BAD_VALUE(ml_tree_load, ml_tree_load(bytes, sz, &loaded), ML_ERR_FORMAT, "bytes: not a manylights tree");
    bytes[0] ^= 1;
    BAD_VALUE(ml_tree_load, ml_tree_load(bytes, sz - 8, &loaded), ML_ERR_FORMAT, "truncated");
    OK(ml_tree_load(bytes, sz, &loaded));
    BAD_NULL(ml_tree_load_with_lights, ml_tree_load_with_lights(bytes, sz, NULL, 4, NULL, &t2),
             "`lights` is NULL");
    BAD_NULL(ml_tree_load_with_lights, ml_tree_load_with_lights(bytes, sz, ls, 4, NULL, NULL),
             "`out` is NULL");
    BAD_VALUE(ml_tree_load_with_lights, ml_tree_load_with_lights(bytes, sz, ls, 3, NULL, &t2),
              ML_ERR_FORMAT, "lights: count is 3, the tree was built from 4 lights");
    ls[1].sphere.center.y = (float)NAN;
    BAD_VALUE(ml_tree_load_with_lights, ml_tree_load_with_lights(bytes, sz, ls, 4, NULL, &t2),
              ML_ERR_INVALID_ARGUMENT, "lights[1].sphere.center is NaN or infinite");
    ls[1].sphere.center.y = 0;
    ls[2].sphere.center.z += 5;
    BAD_VALUE(ml_tree_load_with_lights, ml_tree_load_with_lights(bytes, sz, ls, 4, NULL, &t2),
              ML_ERR_FORMAT, "lights[2] lies outside its slot's bounds");
    ls[2].sphere.center.z -= 5;
    bytes[sz / 2] ^= 4;
    BAD_VALUE(ml_tree_load_with_lights, ml_tree_load_with_lights(bytes, sz, ls, 4, NULL, &t2),
              ML_ERR_FORMAT, "bytes: tree bytes are corrupt: their checksum is");
    bytes[sz / 2] ^= 4;
    CHECK(t2 == NULL);
    OK(ml_tree_load_with_lights(bytes, sz, ls, 4, NULL, &t2));
    OK(ml_tree_free(t2));
    t2 = NULL;
    free(bytes);
    /* The limits, named by their macros with the field's own value. */
    {
        ml_light spot = ls[0];
        memset(&ls[0], 0, sizeof ls[0]);
        ls[0].point.kind = ML_LIGHT_KIND_POINT;
        ls[0].point.position = v3(0, 0, 2);
        ls[0].point.intensity = grey(5e25f / (4 * (float)ML_PI));
        BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, &t2), ML_ERR_INVALID_ARGUMENT,
                  "lights[0].point.intensity gives an energy of 5e25 W, above "
                  "ML_MAX_LIGHT_ENERGY (1e24) (got 3.9788736e24)");
        CHECK(5e25 > ML_MAX_LIGHT_ENERGY);
        ls[0].point.intensity = grey(1);
        ls[0].point.position.x = 2 * ML_MAX_COORDINATE;
        BAD_VALUE(ml_tree_build, ml_tree_build(ls, 4, NULL, NULL, &t2), ML_ERR_INVALID_ARGUMENT,
                  "lights[0].point.position exceeds ML_MAX_COORDINATE (1e15) in magnitude "
                  "(got 2e15)");
        ls[0] = spot;
    }
    CHECK(t2 == NULL);

    /* sampling and pmfs */
    p.position = v3(0, 0, 0);
    p.normal = v3(0, 0, 1);
    p.receiver = ML_RECEIVER_REFLECTIVE;
    r.s = 3;
    sp = make_sp(&r);
    s.light = 777;
    BAD_NULL(ml_tree_sample_tl, ml_tree_sample_tl(tree, NULL, 0.5f, &s), "`point` is NULL");
    BAD_VALUE(ml_tree_sample_tl, ml_tree_sample_tl(tree, &p, 1.0f, &s), ML_ERR_INVALID_ARGUMENT,
              "u must be in [0, 1) (got 1)");
    BAD_VALUE(ml_tree_sample_tl, ml_tree_sample_tl(tree, &p, (float)NAN, &s),
              ML_ERR_INVALID_ARGUMENT, "u must be in [0, 1) (got NaN)");
    p.normal.x = (float)INFINITY;
    BAD_VALUE(ml_tree_sample_tl, ml_tree_sample_tl(tree, &p, 0.5f, &s), ML_ERR_INVALID_ARGUMENT,
              "point.normal is NaN or infinite (got inf)");
    p.normal.x = 0;
    p.receiver = 3;
    BAD_VALUE(ml_tree_sample_tl, ml_tree_sample_tl(tree, &p, 0.5f, &s), ML_ERR_INVALID_ARGUMENT,
              "point.receiver: 3 is not an ml_receiver (0 to 2)");
    BAD_VALUE(ml_tree_pmf_tl, ml_tree_pmf_tl(tree, &p, 0, &f), ML_ERR_INVALID_ARGUMENT,
              "point.receiver: 3 is not an ml_receiver");
    p.receiver = ML_RECEIVER_TRANSMISSIVE;
    CHECK(s.light == 777);
    BAD_NULL(ml_tree_pmf_tl, ml_tree_pmf_tl(tree, &p, 0, NULL), "`out` is NULL");
    BAD_VALUE(ml_tree_pmf_tl, ml_tree_pmf_tl(tree, &p, (uint32_t)n, &f), ML_ERR_INVALID_ARGUMENT,
              "light: light index 10000 is out of range (the tree has 10000 lights)");
    BAD_NULL(ml_tree_sample_bl, ml_tree_sample_bl(tree, NULL, 0.5f, &s), "`sp` is NULL");
    sp.material.alpha = 0;
    BAD_VALUE(ml_tree_sample_bl, ml_tree_sample_bl(tree, &sp, 0.5f, &s), ML_ERR_INVALID_ARGUMENT,
              "sp.material.alpha must be in (0, 1] (got 0)");
    sp.material.alpha = 0.3f;
    sp.material.albedo = rgb(0.5f, 0.5f, 2);
    BAD_VALUE(ml_tree_sample_bl, ml_tree_sample_bl(tree, &sp, 0.5f, &s), ML_ERR_INVALID_ARGUMENT,
              "sp.material.albedo must be in [0, 1] (got 2)");
    sp.material.albedo = grey(0.5f);
    sp.material.kind = 7;
    BAD_VALUE(ml_tree_sample_bl, ml_tree_sample_bl(tree, &sp, 0.5f, &s), ML_ERR_INVALID_ARGUMENT,
              "sp.material.kind: 7 is not an ml_material_kind");
    sp.material.kind = ML_MATERIAL_KIND_GGX;
    sp.wo = v3(0, 0, 0);
    BAD_VALUE(ml_tree_sample_bl, ml_tree_sample_bl(tree, &sp, 0.5f, &s), ML_ERR_INVALID_ARGUMENT,
              "sp.wo has zero length");
    sp.wo = v3(0, 0.5f, 1);
    BAD_NULL(ml_tree_pmf_bl, ml_tree_pmf_bl(NULL, &sp, 0, &f), "`tree` is NULL");
    BAD_VALUE(ml_tree_pmf_bl, ml_tree_pmf_bl(tree, &sp, 4000000000u, &f), ML_ERR_INVALID_ARGUMENT,
              "light index 4000000000 is out of range");

    r.s = 11;
    for (i = 0; i < 8; i++) {
        pts[i] = make_tl_point(&r);
        sps[i] = make_sp(&r);
        us[i] = rng_f32(&r);
        lights[i] = (uint32_t)i;
    }
    outs[0].light = 555;
    BAD_NULL(ml_tree_sample_tl_batch, ml_tree_sample_tl_batch(tree, pts, NULL, 8, outs),
             "`us` is NULL");
    us[3] = -0.5f;
    BAD_VALUE(ml_tree_sample_tl_batch, ml_tree_sample_tl_batch(tree, pts, us, 8, outs),
              ML_ERR_INVALID_ARGUMENT, "us[3] must be in [0, 1) (got -0.5)");
    us[3] = 0.25f;
    pts[5].position.z = (float)NAN;
    BAD_VALUE(ml_tree_sample_tl_batch, ml_tree_sample_tl_batch(tree, pts, us, 8, outs),
              ML_ERR_INVALID_ARGUMENT, "points[5].position is NaN or infinite");
    BAD_VALUE(ml_tree_sample_tl_batch, ml_tree_sample_tl_batch(tree, pts, us, (size_t)-1, outs),
              ML_ERR_INVALID_ARGUMENT, "overflow");
    pts[5].position.z = 0;
    pts[6].receiver = 7;
    BAD_VALUE(ml_tree_sample_tl_batch, ml_tree_sample_tl_batch(tree, pts, us, 8, outs),
              ML_ERR_INVALID_ARGUMENT, "points[6].receiver: 7 is not an ml_receiver");
    BAD_VALUE(ml_tree_pmf_tl_batch, ml_tree_pmf_tl_batch(tree, pts, lights, 8, us),
              ML_ERR_INVALID_ARGUMENT, "points[6].receiver: 7 is not an ml_receiver");
    pts[6].receiver = ML_RECEIVER_OMNIDIRECTIONAL;
    CHECK(outs[0].light == 555);
    BAD_NULL(ml_tree_pmf_tl_batch, ml_tree_pmf_tl_batch(tree, pts, lights, 8, NULL), "`out` is NULL");
    pts[5].position.z = 0;
    lights[2] = (uint32_t)n + 5;
    BAD_VALUE(ml_tree_pmf_tl_batch, ml_tree_pmf_tl_batch(tree, pts, lights, 8, us),
              ML_ERR_INVALID_ARGUMENT, "lights[2]: light index 10005 is out of range");
    lights[2] = 2;
    BAD_NULL(ml_tree_sample_bl_batch, ml_tree_sample_bl_batch(tree, NULL, us, 8, outs),
             "`points` is NULL");
    sps[1].material.alpha = 2;
    BAD_VALUE(ml_tree_sample_bl_batch, ml_tree_sample_bl_batch(tree, sps, us, 8, outs),
              ML_ERR_INVALID_ARGUMENT, "points[1].material.alpha must be in (0, 1] (got 2)");
    sps[1].material.alpha = 0.5f;
    BAD_NULL(ml_tree_pmf_bl_batch, ml_tree_pmf_bl_batch(tree, sps, NULL, 8, us), "`lights` is NULL");
    lights[0] = (uint32_t)-1;
    BAD_VALUE(ml_tree_pmf_bl_batch, ml_tree_pmf_bl_batch(tree, sps, lights, 8, us),
              ML_ERR_INVALID_ARGUMENT, "lights[0]: light index 4294967295 is out of range");
    lights[0] = 0;
    /* Empty batches are fine, with NULL arrays. */
    OK(ml_tree_sample_tl_batch(tree, NULL, NULL, 0, NULL));
    OK(ml_tree_pmf_bl_batch(tree, NULL, NULL, 0, NULL));

    /* points on lights */
    BAD_NULL(ml_light_sample_point, ml_light_sample_point(tree, 0, v3(0, 0, 0), 0.5f, 0.5f, NULL),
             "`out` is NULL");
    BAD_VALUE(ml_light_sample_point, ml_light_sample_point(tree, 0, v3(0, 0, 0), 1.0f, 0.5f, &lp),
              ML_ERR_INVALID_ARGUMENT, "u0 must be in [0, 1) (got 1)");
    BAD_VALUE(ml_light_sample_point,
              ml_light_sample_point(tree, (uint32_t)n, v3(0, 0, 0), 0.5f, 0.5f, &lp),
              ML_ERR_INVALID_ARGUMENT, "light: light index 10000 is out of range");
    BAD_VALUE(ml_light_sample_point,
              ml_light_sample_point(tree, 0, v3((float)NAN, 0, 0), 0.5f, 0.5f, &lp),
              ML_ERR_INVALID_ARGUMENT, "x is NaN or infinite");
    BAD_VALUE(ml_light_sample_point, ml_light_sample_point(loaded, 0, v3(0, 0, 0), 0.5f, 0.5f, &lp),
              ML_ERR_STATE, "no light descriptors");
    BAD_NULL(ml_light_pdf_point, ml_light_pdf_point(NULL, 0, v3(0, 0, 0), v3(0, 0, 1), &f),
             "`tree` is NULL");
    BAD_VALUE(ml_light_pdf_point,
              ml_light_pdf_point(tree, 0, v3(0, 0, 0), v3(0, (float)INFINITY, 1), &f),
              ML_ERR_INVALID_ARGUMENT, "point is NaN or infinite");
    for (i = 0; i < 8; i++) us[i] = 0.5f;
    for (i = 0; i < 4; i++) {
        u32s[i] = (uint32_t)i;
        xs4[i] = v3(0, 0, 0);
    }
    BAD_NULL(ml_light_sample_point_batch,
             ml_light_sample_point_batch(tree, u32s, NULL, us, us, 4, lps), "`xs` is NULL");
    BAD_NULL(ml_light_sample_point_batch,
             ml_light_sample_point_batch(NULL, u32s, xs4, us, us, 4, lps), "`tree` is NULL");
    u32s[2] = (uint32_t)n;
    BAD_VALUE(ml_light_sample_point_batch,
              ml_light_sample_point_batch(tree, u32s, xs4, us, us, 4, lps),
              ML_ERR_INVALID_ARGUMENT, "lights[2]: light index 10000 is out of range");
    u32s[2] = 2;
    us[5] = 1;
    BAD_VALUE(ml_light_sample_point_batch,
              ml_light_sample_point_batch(tree, u32s, xs4, us, us + 4, 4, lps),
              ML_ERR_INVALID_ARGUMENT, "u1s[1] must be in [0, 1) (got 1)");
    us[5] = 0.5f;
    BAD_VALUE(ml_light_sample_point_batch,
              ml_light_sample_point_batch(loaded, u32s, xs4, us, us, 4, lps), ML_ERR_STATE,
              "no light descriptors");

    /* cuts */
    BAD_NULL(ml_cut_create, ml_cut_create(NULL), "`out` is NULL");
    BAD_VALUE(ml_cut_create, ml_cut_create(MISALIGN(ml_cut *, dbl)), ML_ERR_INVALID_ARGUMENT,
              "misaligned");
    OK(ml_cut_create(&cut));
    OK(ml_cut_create(&fresh));
    FREE_NULL(ml_cut_free, ml_cut_free(NULL));
    BAD_NULL(ml_cut_build_bl, ml_cut_build_bl(cut, tree, NULL, NULL), "`sp` is NULL");
    BAD_NULL(ml_cut_build_bl, ml_cut_build_bl(NULL, tree, &sp, NULL), "`cut` is NULL");
    OK(ml_bl_cut_options_default(&co));
    co.max_size = 100;
    BAD_VALUE(ml_cut_build_bl, ml_cut_build_bl(cut, tree, &sp, &co), ML_ERR_INVALID_ARGUMENT,
              "options.max_size must be in [4, 64], ML_MIN_CUT_SIZE to ML_MAX_CUT_SIZE (got 100)");
    co.max_size = 16;
    co.delta = (float)NAN;
    BAD_VALUE(ml_cut_build_bl, ml_cut_build_bl(cut, tree, &sp, &co), ML_ERR_INVALID_ARGUMENT,
              "options.delta must be finite and non-negative");
    co.delta = 0.5f;
    co.split_sin = 1.5f;
    BAD_VALUE(ml_cut_build_bl, ml_cut_build_bl(cut, tree, &sp, &co), ML_ERR_INVALID_ARGUMENT,
              "options.split_sin must be in [0, 1] (got 1.5)");
    co.split_sin = 1.0f;
    OK(ml_cut_build_bl(cut, tree, &sp, &co));
    OK(ml_split_cut_options_default(&so));
    so.threshold = -1;
    BAD_NULL(ml_cut_build_split, ml_cut_build_split(cut, NULL, &p, NULL), "`tree` is NULL");
    BAD_VALUE(ml_cut_build_split, ml_cut_build_split(cut, tree, &p, &so), ML_ERR_INVALID_ARGUMENT,
              "options.threshold must be finite and non-negative (got -1)");
    p.receiver = 3;
    BAD_VALUE(ml_cut_build_split, ml_cut_build_split(cut, tree, &p, NULL), ML_ERR_INVALID_ARGUMENT,
              "point.receiver: 3 is not an ml_receiver (0 to 2)");
    p.receiver = ML_RECEIVER_REFLECTIVE;
    BAD_NULL(ml_cut_size, ml_cut_size(cut, NULL), "`out` is NULL");
    BAD_VALUE(ml_cut_size, ml_cut_size(fresh, &sz), ML_ERR_STATE, "cut: not built yet");
    BAD_NULL(ml_cut_ib, ml_cut_ib(NULL, &f), "`cut` is NULL");
    BAD_VALUE(ml_cut_ib, ml_cut_ib(fresh, &f), ML_ERR_STATE, "not built yet");
    BAD_NULL(ml_cut_max_variance, ml_cut_max_variance(cut, NULL), "`out` is NULL");
    BAD_VALUE(ml_cut_max_variance, ml_cut_max_variance(fresh, &f), ML_ERR_STATE, "not built yet");
    BAD_VALUE(ml_cut_max_variance, ml_cut_max_variance(cut, &f), ML_ERR_STATE,
              "this one is BRDF-oriented");
    BAD_NULL(ml_cut_sample, ml_cut_sample(cut, 0.5f, NULL), "`out` is NULL");
    BAD_VALUE(ml_cut_sample, ml_cut_sample(cut, 2.0f, &s), ML_ERR_INVALID_ARGUMENT,
              "u must be in [0, 1) (got 2)");
    BAD_NULL(ml_cut_pmf, ml_cut_pmf(cut, 0, NULL), "`out` is NULL");
    BAD_VALUE(ml_cut_pmf, ml_cut_pmf(cut, (uint32_t)n, &f), ML_ERR_INVALID_ARGUMENT,
              "light index 10000 is out of range");
    OK(ml_cut_size(cut, &sz));
    BAD_NULL(ml_cut_sample_clusters, ml_cut_sample_clusters(cut, NULL, 3, outs), "`us` is NULL");
    BAD_VALUE(ml_cut_sample_clusters, ml_cut_sample_clusters(cut, us, sz == 3 ? 2 : 3, outs),
              ML_ERR_INVALID_ARGUMENT, "count must be the cut's size");
    BAD_NULL(ml_cut_pmf_in, ml_cut_pmf_in(cut, 0, NULL, &f), "`cluster` is NULL");
    BAD_VALUE(ml_cut_pmf_in, ml_cut_pmf_in(cut, (uint32_t)n + 1, &u32s[0], &f), ML_ERR_INVALID_ARGUMENT,
              "light index 10001 is out of range");

    /* BRDFs */
    BAD_NULL(ml_brdf_sample, ml_brdf_sample(NULL, 0.5f, 0.5f, &bd), "`sp` is NULL");
    BAD_VALUE(ml_brdf_sample, ml_brdf_sample(&sp, 0.5f, 1.0f, &bd), ML_ERR_INVALID_ARGUMENT,
              "u1 must be in [0, 1) (got 1)");
    BAD_NULL(ml_brdf_pdf, ml_brdf_pdf(&sp, v3(0, 0, 1), NULL), "`out` is NULL");
    BAD_VALUE(ml_brdf_pdf, ml_brdf_pdf(&sp, v3(0, 0, 0), &f), ML_ERR_INVALID_ARGUMENT,
              "wi has zero length");
    BAD_NULL(ml_brdf_eval, ml_brdf_eval(NULL, v3(0, 0, 1), &fc), "`sp` is NULL");
    BAD_VALUE(ml_brdf_eval, ml_brdf_eval(&sp, v3((float)NAN, 0, 1), &fc), ML_ERR_INVALID_ARGUMENT,
              "wi is NaN or infinite");

    /* direct estimators */
    BAD_NULL(ml_direct_estimate, ml_direct_estimate(tree, &sp, 0, NULL, NULL, NULL, &e),
             "`uniforms` is NULL");
    BAD_NULL(ml_direct_estimate, ml_direct_estimate(tree, &sp, 0, NULL, NULL, &nullu, &e),
             "`uniforms->next_f32` is NULL");
    BAD_VALUE(ml_direct_estimate, ml_direct_estimate(tree, &sp, 10, NULL, NULL, &u, &e),
              ML_ERR_INVALID_ARGUMENT, "technique: 10 is not an ml_technique (0 to 9)");
    e.r = e.g = e.b = -7;
    BAD_VALUE(ml_direct_estimate, ml_direct_estimate(tree, &sp, ML_TECHNIQUE_TL, NULL, NULL, &badu, &e),
              ML_ERR_INVALID_ARGUMENT, "uniforms: a number from next_f32 or next_f64 is outside [0, 1) (got 1.5)");
    CHECK(e.r == -7 && e.g == -7 && e.b == -7);
    OK(ml_direct_params_default(&dp));
    dp.n_max = 0;
    BAD_VALUE(ml_direct_estimate, ml_direct_estimate(tree, &sp, 0, &dp, NULL, &u, &e),
              ML_ERR_INVALID_ARGUMENT, "params.n_max must be in [1, 64], 1 to ML_MAX_BUDGET (got 0)");
    dp.n_max = 50;
    dp.bl_light_samples = ML_MAX_LIGHT_SAMPLES + 1;
    BAD_VALUE(ml_direct_estimate, ml_direct_estimate(tree, &sp, ML_TECHNIQUE_BL_MIS, &dp, NULL, &u, &e),
              ML_ERR_INVALID_ARGUMENT,
              "params.bl_light_samples must be in [1, 64], 1 to ML_MAX_LIGHT_SAMPLES (got 65)");
    dp.bl_light_samples = 2;
    dp.mixture_cut.split_sin = -1;
    BAD_VALUE(ml_direct_estimate, ml_direct_estimate(tree, &sp, ML_TECHNIQUE_FULL, &dp, NULL, &u, &e),
              ML_ERR_INVALID_ARGUMENT, "params.mixture_cut.split_sin must be in [0, 1] (got -1)");
    dp.mixture_cut.split_sin = 1;
    BAD_VALUE(ml_direct_estimate, ml_direct_estimate(loaded, &sp, 0, NULL, NULL, &u, &e), ML_ERR_STATE,
              "loaded from bytes");
    sps[0] = sp;
    sps[1] = sp;
    BAD_NULL(ml_direct_estimate_batch,
             ml_direct_estimate_batch(tree, NULL, 2, 1, 0, NULL, NULL, &u, dbl), "`points` is NULL");
    BAD_NULL(ml_direct_estimate_batch,
             ml_direct_estimate_batch(tree, sps, 2, 1, 0, NULL, NULL, &u, NULL), "`out` is NULL");
    BAD_VALUE(ml_direct_estimate_batch,
              ml_direct_estimate_batch(tree, sps, 2, 0, 0, NULL, NULL, &u, dbl),
              ML_ERR_INVALID_ARGUMENT, "per_point must be at least 1 (got 0)");
    sps[1].material.alpha = 2;
    BAD_VALUE(ml_direct_estimate_batch,
              ml_direct_estimate_batch(tree, sps, 2, 1, 0, NULL, NULL, &u, dbl),
              ML_ERR_INVALID_ARGUMENT, "points[1].material.alpha must be in (0, 1] (got 2)");
    sps[1].material.alpha = 0.5f;
    dbl[0].r = dbl[1].r = -7;
    BAD_VALUE(ml_direct_estimate_batch,
              ml_direct_estimate_batch(tree, sps, 2, 1, ML_TECHNIQUE_TL, NULL, NULL, &badu, dbl),
              ML_ERR_INVALID_ARGUMENT, "points[0]: uniforms: a number from next_f32 or next_f64 is outside [0, 1) (got 1.5)");
    CHECK(dbl[0].r == -7 && dbl[1].r == -7);
    BAD_VALUE(ml_direct_estimate_batch,
              ml_direct_estimate_batch(loaded, sps, 2, 1, 0, NULL, NULL, &u, dbl), ML_ERR_STATE,
              "loaded from bytes");
    OK(ml_direct_estimate_batch(tree, sps, 2, 1, 0, NULL, NULL, &u, dbl));
    CHECK(dbl[0].g >= 0 && dbl[1].g >= 0);
    vis.occluded = NULL;
    vis.first_hit = nan_hit;
    vis.user_data = NULL;
    /* A stream whose TL sample is a light that lights sp, so that a shadow ray is traced. */
    r.s = 1;
    BAD_VALUE(ml_direct_estimate, ml_direct_estimate(tree, &sp, ML_TECHNIQUE_TL, NULL, &vis, &u, &e),
              ML_ERR_INVALID_ARGUMENT, "visibility->first_hit returned NaN");
    BAD_NULL(ml_estimator_create, ml_estimator_create(NULL, &est), "`tree` is NULL");
    BAD_VALUE(ml_estimator_create, ml_estimator_create(loaded, &est), ML_ERR_STATE, "loaded from bytes");
    OK(ml_estimator_create(tree, &est));
    FREE_NULL(ml_estimator_free, ml_estimator_free(NULL));
    BAD_NULL(ml_estimator_estimate, ml_estimator_estimate(est, NULL, &u, NULL), "`out` is NULL");
    BAD_VALUE(ml_estimator_estimate, ml_estimator_estimate(est, NULL, &u, &e), ML_ERR_STATE,
              "est: not set up");
    BAD_NULL(ml_estimator_start, ml_estimator_start(NULL), "`est` is NULL");
    BAD_VALUE(ml_estimator_start, ml_estimator_start(est), ML_ERR_STATE, "not set up");
    BAD_NULL(ml_estimator_set_point, ml_estimator_set_point(est, NULL, 0, NULL), "`sp` is NULL");
    sp.normal.z = (float)NAN;
    BAD_VALUE(ml_estimator_set_point, ml_estimator_set_point(est, &sp, 0, NULL),
              ML_ERR_INVALID_ARGUMENT, "sp.normal is NaN or infinite");
    sp.normal.z = 1;
    dp.lambert = 7;
    BAD_VALUE(ml_estimator_set_point, ml_estimator_set_point(est, &sp, 0, &dp),
              ML_ERR_INVALID_ARGUMENT, "params.lambert: 7 is not an ml_lambert_mode");
    dp.lambert = 0;
    OK(ml_estimator_set_point(est, &sp, ML_TECHNIQUE_BL_MIS, &dp));
    OK(ml_estimator_start(est));
    BAD_NULL(ml_estimator_next, ml_estimator_next(est, NULL, &step), "`uniforms` is NULL");
    BAD_VALUE(ml_estimator_next, ml_estimator_next(est, &badu, &step), ML_ERR_INVALID_ARGUMENT,
              "outside [0, 1)");
    BAD_NULL(ml_estimator_weigh, ml_estimator_weigh(est, 0, NULL), "`out` is NULL");
    OK(ml_estimator_start(est));
    BAD_VALUE(ml_estimator_weigh, ml_estimator_weigh(est, 0, &w), ML_ERR_STATE,
              "no light step to weigh");
    BAD_NULL(ml_estimator_bsdf_hits,
             ml_estimator_bsdf_hits(est, v3(0, 0, 1), 1, (float)INFINITY, NULL, NULL, u32s), "`each` is NULL");
    BAD_VALUE(ml_estimator_bsdf_hits,
              ml_estimator_bsdf_hits(est, v3(0, 0, 1), 1, (float)INFINITY, on_hit, NULL, u32s),
              ML_ERR_STATE, "no BSDF step to report");
    /* Walk to the light step and the BSDF step of bl-mis, then give each a bad value. */
    for (i = 0; i < 4; i++) {
        OK(ml_estimator_next(est, &u, &step));
        if (step.kind == ML_STEP_KIND_LIGHT) {
            BAD_VALUE(ml_estimator_weigh, ml_estimator_weigh(est, (float)NAN, &w),
                      ML_ERR_INVALID_ARGUMENT, "bsdf_pdf must be finite and non-negative (got NaN)");
        } else if (step.kind == ML_STEP_KIND_BSDF) {
            host_hit h;
            memset(&h, 0, sizeof h);
            BAD_VALUE(ml_estimator_bsdf_hits,
                      ml_estimator_bsdf_hits(est, v3(0, 0, 0), 1, (float)INFINITY, on_hit, &h, u32s),
                      ML_ERR_INVALID_ARGUMENT, "direction must be finite and non-zero");
            BAD_VALUE(ml_estimator_bsdf_hits,
                      ml_estimator_bsdf_hits(est, v3(0, 0, 1), 1, -1, on_hit, &h, u32s),
                      ML_ERR_INVALID_ARGUMENT, "hit_distance must be non-negative or +infinity (got -1)");
        }
    }
    OK(ml_estimator_free(est));

    bad_input_infinite();

    /* VPL acceptance */
    OK(ml_acceptor_options_default(&ao));
    BAD_NULL(ml_acceptor_create, ml_acceptor_create(NULL, &acc), "`options` is NULL");
    BAD_VALUE(ml_acceptor_create, ml_acceptor_create(&ao, &acc), ML_ERR_INVALID_ARGUMENT,
              "options.pixels must be positive (got 0)");
    ao.pixels = 100;
    ao.wanted = 10;
    ao.epsilon = -1;
    BAD_VALUE(ml_acceptor_create, ml_acceptor_create(&ao, &acc), ML_ERR_INVALID_ARGUMENT,
              "options.epsilon must be positive (got -1)");
    CHECK(acc == NULL);
    ao.epsilon = 0.05f;
    OK(ml_acceptor_create(&ao, &acc));
    FREE_NULL(ml_acceptor_free, ml_acceptor_free(NULL));
    memset(imps, 0, sizeof imps);
    for (i = 0; i < 4; i++) {
        imps[i].hit = 1;
        imps[i].normal = v3(0, 0, 1);
        imps[i].wo = v3(0, 0, 1);
        imps[i].material = lambert(0.5f);
    }
    BAD_NULL(ml_acceptor_set_importons, ml_acceptor_set_importons(acc, NULL, 4), "`importons` is NULL");
    imps[2].normal = v3(0, 0, 0);
    BAD_VALUE(ml_acceptor_set_importons, ml_acceptor_set_importons(acc, imps, 4),
              ML_ERR_INVALID_ARGUMENT, "importons[2].normal has zero length");
    imps[2].normal = v3(0, 0, 1);
    imps[1].hit = 3;
    BAD_VALUE(ml_acceptor_set_importons, ml_acceptor_set_importons(acc, imps, 4),
              ML_ERR_INVALID_ARGUMENT, "importons[1].hit must be 0 or 1 (got 3)");
    imps[1].hit = 1;
    imps[3].material = plastic(2, 0.5f, 0.5f);
    BAD_VALUE(ml_acceptor_set_importons, ml_acceptor_set_importons(acc, imps, 4),
              ML_ERR_INVALID_ARGUMENT, "importons[3].material");
    BAD_NULL(ml_acceptor_update, ml_acceptor_update(NULL, 1), "`acc` is NULL");
    BAD_VALUE(ml_acceptor_update, ml_acceptor_update(acc, (double)NAN), ML_ERR_INVALID_ARGUMENT,
              "frame_luminance is NaN or infinite");
    BAD_VALUE(ml_acceptor_update, ml_acceptor_update(acc, -3), ML_ERR_INVALID_ARGUMENT,
              "frame_luminance is negative (got -3)");
    BAD_NULL(ml_acceptor_set_total_luminance, ml_acceptor_set_total_luminance(NULL, 1), "`acc` is NULL");
    BAD_VALUE(ml_acceptor_set_total_luminance, ml_acceptor_set_total_luminance(acc, (double)INFINITY),
              ML_ERR_INVALID_ARGUMENT, "total is NaN or infinite");
    cand.position = v3(0, 0, 1);
    cand.normal = v3(0, 0, -1);
    cand.intensity = grey(1);
    BAD_NULL(ml_acceptor_accept, ml_acceptor_accept(acc, NULL, 0.5f, NULL, &dec), "`candidate` is NULL");
    BAD_VALUE(ml_acceptor_accept, ml_acceptor_accept(acc, &cand, 1.0f, NULL, &dec),
              ML_ERR_INVALID_ARGUMENT, "xi must be in [0, 1) (got 1)");
    vvis.visible = NULL;
    vvis.user_data = NULL;
    BAD_NULL(ml_acceptor_accept, ml_acceptor_accept(acc, &cand, 0.5f, &vvis, &dec),
             "`visibility->visible` is NULL");
    cand.intensity = rgb(1, 1, -1);
    BAD_VALUE(ml_acceptor_accept, ml_acceptor_accept(acc, &cand, 0.5f, NULL, &dec),
              ML_ERR_INVALID_ARGUMENT, "candidate.intensity is negative (got -1)");
    cand.intensity = grey(1);
    cand.normal = v3(0, 0, 0);
    BAD_NULL(ml_acceptor_probability, ml_acceptor_probability(acc, &cand, NULL, NULL), "`out` is NULL");
    BAD_VALUE(ml_acceptor_probability, ml_acceptor_probability(acc, &cand, NULL, &f),
              ML_ERR_INVALID_ARGUMENT, "candidate.normal has zero length");
    BAD_NULL(ml_acceptor_stats, ml_acceptor_stats(acc, NULL), "`out` is NULL");
    BAD_VALUE(ml_acceptor_stats, ml_acceptor_stats(acc, MISALIGN(ml_accept_stats, &ast)),
              ML_ERR_INVALID_ARGUMENT, "misaligned");
    BAD_NULL(ml_acceptor_reset_stats, ml_acceptor_reset_stats(NULL), "`acc` is NULL");
    BAD_VALUE(ml_acceptor_reset_stats, ml_acceptor_reset_stats(MISALIGN(ml_acceptor, acc)),
              ML_ERR_INVALID_ARGUMENT, "`acc` is misaligned");
    OK(ml_acceptor_free(acc));

    /* Handles given to the wrong functions' misaligned siblings. */
    BAD_VALUE(ml_tree_free, ml_tree_free(MISALIGN(ml_tree, t)), ML_ERR_INVALID_ARGUMENT, "misaligned");
    BAD_VALUE(ml_cut_free, ml_cut_free(MISALIGN(ml_cut, cut)), ML_ERR_INVALID_ARGUMENT, "misaligned");
    BAD_VALUE(ml_estimator_free, ml_estimator_free(MISALIGN(ml_estimator, cut)),
              ML_ERR_INVALID_ARGUMENT, "misaligned");
    BAD_VALUE(ml_acceptor_free, ml_acceptor_free(MISALIGN(ml_acceptor, cut)), ML_ERR_INVALID_ARGUMENT,
              "misaligned");
    (void)q;
    OK(ml_cut_free(cut));
    OK(ml_cut_free(fresh));
    OK(ml_tree_free(loaded));
    OK(ml_tree_free(t));
}

#endif
