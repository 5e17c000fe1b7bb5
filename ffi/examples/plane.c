/*
 * A plane lit by many lights, through the C ABI: a grey-scale PPM of a glossy plane and a
 * diffuse ball, lit by 2,000 small sphere lights and a few spot lights, rendered with the
 * default technique (bl-mis) and shadow rays against the ball.
 *
 * Build against an installed library and run:
 *   cc -std=c99 -O2 plane.c $(pkg-config --cflags --libs manylights) -lm -o plane
 *   ./plane 160 120 8 plane.ppm        # width height samples-per-pixel output
 */
#include <manylights.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* ---- the host's uniform numbers: a 64-bit LCG ---------------------------------------- */

typedef struct lcg {
    uint64_t s;
} lcg;

static double next_f64(void *user) {
    lcg *g = (lcg *)user;
    g->s = g->s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(g->s >> 11) * (1.0 / 9007199254740992.0);
}

static float next_f32(void *user) {
    float f = (float)next_f64(user);
    return f < 1.0f ? f : 0.99999994f;
}

/* ---- the scene: the plane z = 0 and a ball ------------------------------------------- */

static const ml_vec3 ball = {0.0f, 0.0f, 0.6f};
static const float ball_r = 0.6f;

static ml_vec3 add(ml_vec3 a, ml_vec3 b, float t) {
    ml_vec3 v = {a.x + b.x * t, a.y + b.y * t, a.z + b.z * t};
    return v;
}

/* Distance along the unit ray (o, d) to the ball, or +infinity. */
static float hit_ball(ml_vec3 o, ml_vec3 d) {
    float ox = o.x - ball.x, oy = o.y - ball.y, oz = o.z - ball.z;
    float b = ox * d.x + oy * d.y + oz * d.z;
    float c = ox * ox + oy * oy + oz * oz - ball_r * ball_r;
    float disc = b * b - c, t;
    if (disc < 0) return INFINITY;
    t = -b - sqrtf(disc);
    if (t > 1e-4f) return t;
    t = -b + sqrtf(disc);
    return t > 1e-4f ? t : INFINITY;
}

/* The shadow ray of the estimators: is the ball in the way before distance t? */
static int32_t occluded(void *user, ml_vec3 x, ml_vec3 d, float t) {
    (void)user;
    return hit_ball(x, d) < t * 0.9999f;
}

static ml_light *make_lights(size_t *count) {
    size_t n = 2000 + 6, i;
    ml_light *ls = (ml_light *)calloc(n, sizeof(ml_light));
    lcg g = {7};
    for (i = 0; i < 2000; i++) {
        float a = (float)(next_f64(&g) * 6.283185307179586);
        float r = 1.2f + 2.8f * (float)sqrt(next_f64(&g));
        ls[i].sphere.kind = ML_LIGHT_KIND_SPHERE;
        ls[i].sphere.center.x = r * cosf(a);
        ls[i].sphere.center.y = r * sinf(a);
        ls[i].sphere.center.z = 0.15f + 1.5f * (float)next_f64(&g);
        ls[i].sphere.radius = 0.02f;
        {
            /* Radiance 20 × (0.2 to 1.2), alternately warm and cool white (linear RGB). */
            float p = 20.0f * (0.2f + (float)next_f64(&g));
            ls[i].sphere.radiance.r = p * (i % 2 ? 0.8f : 1.2f);
            ls[i].sphere.radiance.g = p;
            ls[i].sphere.radiance.b = p * (i % 2 ? 1.25f : 0.7f);
        }
    }
    for (; i < n; i++) {
        float a = (float)(i - 2000) * 1.0471976f;
        ml_spot_light *s = &ls[i].spot;
        s->kind = ML_LIGHT_KIND_SPOT;
        s->position.x = 2.5f * cosf(a);
        s->position.y = 2.5f * sinf(a);
        s->position.z = 3.0f;
        s->axis.x = -s->position.x;
        s->axis.y = -s->position.y;
        s->axis.z = -s->position.z;
        s->intensity.r = s->intensity.g = s->intensity.b = 4.0f;
        s->half_angle = 0.35f;
        s->falloff_start = 0.25f;
    }
    *count = n;
    return ls;
}

static int check(ml_status s, const char *what) {
    if (s != ML_OK) {
        fprintf(stderr, "%s: %s\n", what, ml_last_error_message());
        return 0;
    }
    return 1;
}

int main(int argc, char **argv) {
    int width = argc > 1 ? atoi(argv[1]) : 160;
    int height = argc > 2 ? atoi(argv[2]) : 120;
    int spp = argc > 3 ? atoi(argv[3]) : 8;
    const char *path = argc > 4 ? argv[4] : "plane.ppm";
    size_t n_lights;
    ml_light *lights = make_lights(&n_lights);
    ml_tree *tree = NULL;
    ml_estimator *est = NULL;
    ml_visibility vis = {.occluded = occluded, .first_hit = NULL, .user_data = NULL};
    lcg g = {2024};
    ml_uniforms uniforms = {.next_f32 = next_f32, .next_f64 = next_f64, .user_data = &g};
    unsigned char *image;
    FILE *f;
    int x, y, k, ok = 1;
    const ml_vec3 eye = {0.0f, -5.0f, 3.2f};

    if (width <= 0 || height <= 0 || spp <= 0) {
        fprintf(stderr, "usage: %s [width height spp output.ppm]\n", argv[0]);
        return 2;
    }
    image = (unsigned char *)malloc((size_t)width * (size_t)height * 3);
    if (!check(ml_tree_build(lights, n_lights, NULL, NULL, &tree), "ml_tree_build") ||
        !check(ml_estimator_create(tree, &est), "ml_estimator_create")) {
        return 1;
    }

    for (y = 0; y < height && ok; y++) {
        for (x = 0; x < width && ok; x++) {
            double sum[3] = {0, 0, 0};
            for (k = 0; k < spp && ok; k++) {
                /* A pinhole camera looking at the origin (jittered within the pixel). */
                float px = ((float)x + next_f32(&g)) / (float)width * 2 - 1;
                float py = 1 - ((float)y + next_f32(&g)) / (float)height * 2;
                ml_vec3 d = {px * 0.6f * (float)width / (float)height, 0.83f, -0.55f + py * 0.6f};
                float len = sqrtf(d.x * d.x + d.y * d.y + d.z * d.z), tb, tp;
                ml_shading_point sp;
                ml_rgb64 e = {0, 0, 0};
                d.x /= len;
                d.y /= len;
                d.z /= len;
                tb = hit_ball(eye, d);
                tp = d.z < 0 ? -eye.z / d.z : INFINITY;
                if (tb == INFINITY && tp == INFINITY) continue;
                sp.wo.x = -d.x;
                sp.wo.y = -d.y;
                sp.wo.z = -d.z;
                if (tb < tp) {
                    sp.position = add(eye, d, tb);
                    sp.normal.x = (sp.position.x - ball.x) / ball_r;
                    sp.normal.y = (sp.position.y - ball.y) / ball_r;
                    sp.normal.z = (sp.position.z - ball.z) / ball_r;
                    sp.material.kind = ML_MATERIAL_KIND_LAMBERT;
                    sp.material.albedo.r = 0.8f;
                    sp.material.albedo.g = 0.35f;
                    sp.material.albedo.b = 0.2f;
                    sp.material.specular = 0;
                    sp.material.alpha = 1;
                } else {
                    sp.position = add(eye, d, tp);
                    sp.position.z = 0;
                    sp.normal.x = 0;
                    sp.normal.y = 0;
                    sp.normal.z = 1;
                    sp.material.kind = ML_MATERIAL_KIND_PLASTIC;
                    sp.material.albedo.r = sp.material.albedo.g = sp.material.albedo.b = 0.5f;
                    sp.material.specular = 0.5f;
                    sp.material.alpha = 0.15f;
                }
                ok = check(ml_estimator_set_point(est, &sp, ML_TECHNIQUE_DEFAULT, NULL),
                           "ml_estimator_set_point") &&
                     check(ml_estimator_estimate(est, &vis, &uniforms, &e), "ml_estimator_estimate");
                sum[0] += e.r;
                sum[1] += e.g;
                sum[2] += e.b;
            }
            {
                /* Reinhard tone mapping per channel, then sRGB-like gamma. */
                size_t o = ((size_t)y * (size_t)width + (size_t)x) * 3, c;
                for (c = 0; c < 3; c++) {
                    double v = sum[c] / spp * 0.5;
                    image[o + c] = (unsigned char)(255.0 * pow(v / (1.0 + v), 1.0 / 2.2) + 0.5);
                }
            }
        }
    }

    f = ok ? fopen(path, "wb") : NULL;
    if (f != NULL) {
        fprintf(f, "P6\n%d %d\n255\n", width, height);
        fwrite(image, 1, (size_t)width * (size_t)height * 3, f);
        fclose(f);
        printf("wrote %s (%dx%d, %d spp, %zu lights)\n", path, width, height, spp, n_lights);
    } else if (ok) {
        fprintf(stderr, "cannot write %s\n", path);
        ok = 0;
    }
    ml_estimator_free(est);
    ml_tree_free(tree);
    free(image);
    free(lights);
    return ok ? 0 : 1;
}
