// A plane lit by many lights, through the C++17 wrapper manylights.hpp: examples/plane.c
// written with it (RAII handles, exceptions, lambdas as callbacks), the same image byte for
// byte and the same output line.
//
// Build against an installed library (through CMake: examples/cmake) and run:
//   c++ -std=c++17 -O2 plane.cpp $(pkg-config --cflags --libs manylights) -o plane_cpp
//   ./plane_cpp 160 120 8 plane.ppm        # width height samples-per-pixel output
#include <manylights.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <vector>

namespace {

// ---- the host's uniform numbers: a 64-bit LCG ------------------------------------------

struct Lcg {
    uint64_t s;
    double next_f64() {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        return static_cast<double>(s >> 11) * (1.0 / 9007199254740992.0);
    }
    float next_f32() {
        float f = static_cast<float>(next_f64());
        return f < 1.0f ? f : 0.99999994f;
    }
};

// ---- the scene: the plane z = 0 and a ball ---------------------------------------------

const ml_vec3 ball = {0.0f, 0.0f, 0.6f};
const float ball_r = 0.6f;

ml_vec3 add(ml_vec3 a, ml_vec3 b, float t) { return {a.x + b.x * t, a.y + b.y * t, a.z + b.z * t}; }

// Distance along the unit ray (o, d) to the ball, or +infinity.
float hit_ball(ml_vec3 o, ml_vec3 d) {
    float ox = o.x - ball.x, oy = o.y - ball.y, oz = o.z - ball.z;
    float b = ox * d.x + oy * d.y + oz * d.z;
    float c = ox * ox + oy * oy + oz * oz - ball_r * ball_r;
    float disc = b * b - c;
    if (disc < 0) return INFINITY;
    float t = -b - std::sqrt(disc);
    if (t > 1e-4f) return t;
    t = -b + std::sqrt(disc);
    return t > 1e-4f ? t : INFINITY;
}

std::vector<ml_light> make_lights() {
    std::vector<ml_light> ls;
    ls.reserve(2006);
    Lcg g{7};
    for (int i = 0; i < 2000; i++) {
        float a = static_cast<float>(g.next_f64() * 6.283185307179586);
        float r = 1.2f + 2.8f * static_cast<float>(std::sqrt(g.next_f64()));
        ml_vec3 center{r * std::cos(a), r * std::sin(a), 0.0f};
        center.z = 0.15f + 1.5f * static_cast<float>(g.next_f64());
        // Radiance 20 × (0.2 to 1.2), alternately warm and cool white (linear RGB).
        float p = 20.0f * (0.2f + static_cast<float>(g.next_f64()));
        ml_rgb radiance{p * (i % 2 ? 0.8f : 1.2f), p, p * (i % 2 ? 1.25f : 0.7f)};
        ls.push_back(ml::sphere_light(center, 0.02f, radiance));
    }
    for (int i = 2000; i < 2006; i++) {
        float a = static_cast<float>(i - 2000) * 1.0471976f;
        ml_vec3 position{2.5f * std::cos(a), 2.5f * std::sin(a), 3.0f};
        ml_vec3 axis{-position.x, -position.y, -position.z};
        ls.push_back(ml::spot_light(position, axis, {4.0f, 4.0f, 4.0f}, 0.35f, 0.25f));
    }
    return ls;
}

int run(int width, int height, int spp, const char *path) {
    const std::vector<ml_light> lights = make_lights();
    const ml::Tree tree = ml::Tree::build(lights);
    ml::Estimator est = ml::Estimator::create(tree);
    Lcg g{2024};
    // The shadow ray of the estimators: is the ball in the way before distance t?
    auto shadow = ml::shadow_rays(
        [](ml_vec3 x, ml_vec3 d, float t) { return hit_ball(x, d) < t * 0.9999f; });
    auto uniforms = ml::uniforms([&g] { return g.next_f32(); }, [&g] { return g.next_f64(); });
    const ml_vec3 eye = {0.0f, -5.0f, 3.2f};
    std::vector<unsigned char> image(static_cast<std::size_t>(width) * height * 3);

    for (int y = 0; y < height; y++) {
        for (int x = 0; x < width; x++) {
            double sum[3] = {0, 0, 0};
            for (int k = 0; k < spp; k++) {
                // A pinhole camera looking at the origin (jittered within the pixel).
                float px = (static_cast<float>(x) + g.next_f32()) / static_cast<float>(width) * 2 - 1;
                float py = 1 - (static_cast<float>(y) + g.next_f32()) / static_cast<float>(height) * 2;
                ml_vec3 d = {px * 0.6f * static_cast<float>(width) / static_cast<float>(height),
                             0.83f, -0.55f + py * 0.6f};
                float len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
                d.x /= len;
                d.y /= len;
                d.z /= len;
                float tb = hit_ball(eye, d);
                float tp = d.z < 0 ? -eye.z / d.z : INFINITY;
                if (tb == INFINITY && tp == INFINITY) continue;
                ml_shading_point sp{};
                sp.wo = {-d.x, -d.y, -d.z};
                if (tb < tp) {
                    sp.position = add(eye, d, tb);
                    sp.normal = {(sp.position.x - ball.x) / ball_r, (sp.position.y - ball.y) / ball_r,
                                 (sp.position.z - ball.z) / ball_r};
                    sp.material = ml::lambert({0.8f, 0.35f, 0.2f});
                } else {
                    sp.position = add(eye, d, tp);
                    sp.position.z = 0;
                    sp.normal = {0, 0, 1};
                    sp.material = ml::plastic({0.5f, 0.5f, 0.5f}, 0.5f, 0.15f);
                }
                est.set_point(sp, ML_TECHNIQUE_DEFAULT);
                ml_rgb64 e = est.estimate(shadow, uniforms);
                sum[0] += e.r;
                sum[1] += e.g;
                sum[2] += e.b;
            }
            // Reinhard tone mapping per channel, then sRGB-like gamma.
            std::size_t o = (static_cast<std::size_t>(y) * width + x) * 3;
            for (std::size_t c = 0; c < 3; c++) {
                double v = sum[c] / spp * 0.5;
                image[o + c] =
                    static_cast<unsigned char>(255.0 * std::pow(v / (1.0 + v), 1.0 / 2.2) + 0.5);
            }
        }
    }

    std::FILE *f = std::fopen(path, "wb");
    if (f == nullptr) {
        std::fprintf(stderr, "cannot write %s\n", path);
        return 1;
    }
    std::fprintf(f, "P6\n%d %d\n255\n", width, height);
    std::fwrite(image.data(), 1, image.size(), f);
    std::fclose(f);
    std::printf("wrote %s (%dx%d, %d spp, %zu lights)\n", path, width, height, spp, lights.size());
    return 0;
}

}  // namespace

int main(int argc, char **argv) {
    int width = argc > 1 ? std::atoi(argv[1]) : 160;
    int height = argc > 2 ? std::atoi(argv[2]) : 120;
    int spp = argc > 3 ? std::atoi(argv[3]) : 8;
    const char *path = argc > 4 ? argv[4] : "plane.ppm";
    if (width <= 0 || height <= 0 || spp <= 0) {
        std::fprintf(stderr, "usage: %s [width height spp output.ppm]\n", argv[0]);
        return 2;
    }
    try {
        return run(width, height, spp, path);
    } catch (const ml::Error &e) {
        std::fprintf(stderr, "%s: %s\n", e.status_name(), e.what());
        return 1;
    }
}
