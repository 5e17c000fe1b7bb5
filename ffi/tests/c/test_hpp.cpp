// The C++17 wrapper manylights.hpp: every class, every free function and every method (the
// throwing and the `try_` form) used at least once (tests/c_programs.rs checks the names),
// against the C ABI's own answers and closed forms: moves leave empty handles, errors carry
// the status and a message naming the light index and field, the wrapper's span checks,
// callables' exceptions rethrown after the C call, the environment kept alive by what was
// made from its tree.
//
// Usage: test_hpp (prints "test_hpp: N checks, 0 failures" and exits 0 on success)
#include "manylights.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

int g_checks = 0;
int g_failures = 0;

#define CHECK(cond)                                                                      \
    do {                                                                                 \
        ++g_checks;                                                                      \
        if (!(cond)) {                                                                   \
            std::fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
            ++g_failures;                                                                \
        }                                                                                \
    } while (0)

// Runs `body`, which must throw `E`; returns the exception's copy for further checks.
template <class E, class Body>
bool throws(Body &&body, E *out = nullptr) {
    try {
        body();
    } catch (const E &e) {
        if (out != nullptr) *out = e;
        return true;
    } catch (...) {
        return false;
    }
    return false;
}

bool contains(const std::string &s, const char *part) { return s.find(part) != std::string::npos; }

uint32_t bits(float f) {
    uint32_t b;
    std::memcpy(&b, &f, sizeof b);
    return b;
}

// A SplitMix64 generator: uniform numbers in [0, 1).
struct Rng {
    uint64_t s;
    uint64_t next() {
        uint64_t z = (s += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    float f32() { return static_cast<float>(next() >> 40) * (1.0f / 16777216.0f); }
    double f64() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
};

const float kPi = 3.14159265358979f;

// A Lambert point on the plane z = 0 looking up.
ml_shading_point plane_point(float x, float y, float rho) {
    ml_shading_point sp{};
    sp.position = {x, y, 0};
    sp.normal = {0, 0, 1};
    sp.wo = {0.2f, 0.1f, 1};
    sp.material = ml::lambert({rho, rho, rho});
    return sp;
}

// Lights of every kind (the helpers), with fields checked against the union.
std::vector<ml_light> every_kind() {
    std::vector<ml_light> ls;
    ls.push_back(ml::point_light({0, 0, 2}, {1, 2, 3}));
    ls.push_back(ml::spot_light({1, 0, 3}, {0, 0, -1}, {2, 2, 2}, 0.6f, 0.3f));
    ls.push_back(ml::sphere_light({-1, 1, 2}, 0.2f, {1, 1, 1}));
    ls.push_back(ml::disk_light({0, 2, 2}, {0, 0, -1}, 0.3f, {1, 0.5f, 0.25f}, true));
    ls.push_back(ml::triangle_light({0, 0, 3}, {1, 0, 3}, {0, 1, 3}, {3, 3, 3}));
    ls.push_back(ml::vpl_light({2, 2, 1}, {0, 0, -1}, {0.5f, 0.5f, 0.5f}));
    ls.push_back(ml::distant_light({0.3f, 0.2f, 1}, 0.01f, {2, 2, 2}));
    CHECK(ls[0].kind == ML_LIGHT_KIND_POINT && ls[0].point.intensity.b == 3);
    CHECK(ls[1].kind == ML_LIGHT_KIND_SPOT && ls[1].spot.half_angle == 0.6f &&
          ls[1].spot.falloff_start == 0.3f);
    CHECK(ls[2].kind == ML_LIGHT_KIND_SPHERE && ls[2].sphere.radius == 0.2f);
    CHECK(ls[3].kind == ML_LIGHT_KIND_DISK && ls[3].disk.two_sided == 1);
    CHECK(ls[4].kind == ML_LIGHT_KIND_TRIANGLE && ls[4].triangle.two_sided == 0 &&
          ls[4].triangle.v1.x == 1);
    CHECK(ls[5].kind == ML_LIGHT_KIND_VPL && ls[5].vpl.normal.z == -1);
    CHECK(ls[6].kind == ML_LIGHT_KIND_DISTANT && ls[6].distant.angular_radius == 0.01f);
    return ls;
}

void values() {
    ml::Version v = ml::version();
    CHECK(v.major == ML_VERSION_MAJOR && v.minor == ML_VERSION_MINOR && v.patch == ML_VERSION_PATCH);
    CHECK(std::string(ml::status_name(ML_ERR_NULL)) == "ML_ERR_NULL");
    CHECK(std::string(ml::status_name(12345)) == "unknown");
    CHECK(ml::build_options().buckets == 0 || ml::build_options().buckets == 12);
    CHECK(ml::bl_cut_options().max_size == 64 && ml::bl_cut_options().delta == 0.3f);
    CHECK(ml::split_cut_options().max_size == 32);
    ml_direct_params p = ml::direct_params();
    CHECK(p.bl_light_samples == 2 && p.n_max == 50);
    ml_acceptor_options o = ml::acceptor_options(100, 10);
    CHECK(o.pixels == 100 && o.wanted == 10 && o.epsilon == 0.05f);
    ml_material g = ml::ggx(0.7f, 0.3f);
    CHECK(g.kind == ML_MATERIAL_KIND_GGX && g.specular == 0.7f && g.alpha == 0.3f);
    ml_material pl = ml::plastic({0.5f, 0.4f, 0.3f}, 0.5f, 0.2f);
    CHECK(pl.kind == ML_MATERIAL_KIND_PLASTIC && pl.albedo.g == 0.4f);
}

void spans() {
    std::vector<float> v{1, 2, 3};
    const std::vector<float> cv{4, 5};
    std::array<float, 4> a{{6, 7, 8, 9}};
    const std::array<float, 2> ca{{1, 1}};
    float c[5] = {0, 0, 0, 0, 1};
    ml::Span<float> sv(v);
    ml::Span<const float> scv(cv), sa(a), sca(ca), sc(c), sptr(v.data(), 2), from_mut(sv);
    ml::Span<float> empty;
    CHECK(sv.size() == 3 && sv[2] == 3 && scv.size() == 2 && scv[1] == 5);
    CHECK(sa.size() == 4 && sa[0] == 6 && sca.size() == 2 && sc.size() == 5 && sc[4] == 1);
    CHECK(sptr.size() == 2 && sptr.data() == v.data() && from_mut.size() == 3);
    CHECK(empty.empty() && empty.data() == nullptr && !sv.empty());
    float sum = 0;
    for (float x : sa) sum += x;
    CHECK(sum == 30 && sa.end() - sa.begin() == 4);
    sv[0] = 10;
    CHECK(v[0] == 10);
}

void errors_and_moves() {
    std::vector<ml_light> ls = every_kind();
    ls[2].sphere.radius = -1;  // light 2's field
    ml::Error e(ML_OK, "");
    CHECK(throws<ml::Error>([&] { (void)ml::Tree::build(ls); }, &e));
    CHECK(e.status() == ML_ERR_INVALID_ARGUMENT);
    CHECK(std::string(e.status_name()) == "ML_ERR_INVALID_ARGUMENT");
    CHECK(contains(e.what(), "lights[2].sphere.radius"));
    // The non-throwing form: the same status and message, value() throwing the error.
    ml::Result<ml::Tree> r = ml::Tree::try_build(ls);
    CHECK(!r.ok() && !r && r.status() == ML_ERR_INVALID_ARGUMENT);
    CHECK(r.message() == e.what());
    CHECK(throws<ml::Error>([&] { (void)r.value(); }));
    ls[2].sphere.radius = 0.2f;

    // Tree: moves leave an empty handle whose calls fail with ML_ERR_NULL.
    ml::Result<ml::Tree> ok = ml::Tree::try_build(ls);
    CHECK(ok.ok() && ok.status() == ML_OK && ok.message().empty());
    ml::Tree a = std::move(ok).value();
    ml_tree *raw = a.get();
    CHECK(a && raw != nullptr);
    ml::Tree b(std::move(a));
    CHECK(!a && a.get() == nullptr && b.get() == raw);  // NOLINT: use after move on purpose
    CHECK(a.try_stats().status() == ML_ERR_NULL);
    ml::Tree c;
    CHECK(!c);
    c = std::move(b);
    CHECK(!b && c.get() == raw && c.stats().lights == 7);
    c = ml::Tree::build(ls);  // the old tree freed, the new one held
    CHECK(c && c.get() != nullptr);

    ml::Estimator e1 = ml::Estimator::create(c);
    ml_estimator *re = e1.get();
    ml::Estimator e2(std::move(e1));
    CHECK(!e1 && e1.get() == nullptr && e2.get() == re);
    ml::Estimator e3;
    e3 = std::move(e2);
    CHECK(!e2 && e3.get() == re);
    CHECK(e1.try_start().status() == ML_ERR_NULL);

    ml::Cut k1 = ml::Cut::create();
    ml_cut *rk = k1.get();
    ml::Cut k2(std::move(k1));
    ml::Cut k3;
    k3 = std::move(k2);
    CHECK(!k1 && !k2 && k3.get() == rk);
    CHECK(k1.try_size().status() == ML_ERR_NULL);

    ml::Acceptor q1 = ml::Acceptor::create(ml::acceptor_options(64, 8));
    ml_acceptor *rq = q1.get();
    ml::Acceptor q2(std::move(q1));
    ml::Acceptor q3;
    q3 = std::move(q2);
    CHECK(!q1 && !q2 && q3.get() == rq);
    CHECK(q1.try_reset_stats().status() == ML_ERR_NULL);

    // Handles adopting C handles.
    ml_cut *raw_cut = nullptr;
    CHECK(ml_cut_create(&raw_cut) == ML_OK);
    ml::Cut adopted(raw_cut);
    CHECK(adopted.get() == raw_cut);
    ml_tree *raw_tree = nullptr;
    CHECK(ml_tree_build(ls.data(), ls.size(), nullptr, nullptr, &raw_tree) == ML_OK);
    ml::Tree adopted_tree(raw_tree);
    ml_estimator *raw_est = nullptr;
    CHECK(ml_estimator_create(raw_tree, &raw_est) == ML_OK);
    ml::Estimator adopted_est(raw_est);
    ml_acceptor_options o = ml::acceptor_options(4, 2);
    ml_acceptor *raw_acc = nullptr;
    CHECK(ml_acceptor_create(&o, &raw_acc) == ML_OK);
    ml::Acceptor adopted_acc(raw_acc);
    CHECK(adopted_tree.get() == raw_tree && adopted_est.get() == raw_est &&
          adopted_acc.get() == raw_acc);
}

void tree_queries() {
    const std::vector<ml_light> ls = every_kind();
    const ml::Tree tree = ml::Tree::build(ls, nullptr);
    ml_build_options bo = ml::build_options();
    bo.buckets = 16;
    const ml::Tree tree16 = ml::Tree::build(ls, &bo);
    ml_tree_statistics st = tree.stats();
    CHECK(st.lights == 7 && st.has_lights == 1 && tree.try_stats().ok() && tree16.stats().nodes >= 1);

    Rng r{11};
    const std::size_t n = 64;
    std::vector<ml_tl_point> tps(n);
    std::vector<ml_shading_point> sps(n);
    std::vector<float> us(n);
    std::vector<uint32_t> which(n);
    for (std::size_t i = 0; i < n; i++) {
        tps[i] = ml_tl_point{{r.f32() * 4 - 2, r.f32() * 4 - 2, 0}, {0, 0, 1}, ML_RECEIVER_REFLECTIVE};
        sps[i] = plane_point(tps[i].position.x, tps[i].position.y, 0.5f);
        us[i] = r.f32();
        which[i] = static_cast<uint32_t>(i % 7);
    }
    std::vector<ml_sampled_light> tl(n), bl(n);
    std::vector<float> ptl(n), pbl(n);
    tree.sample_tl_batch(tps, us, tl);
    tree.pmf_tl_batch(tps, which, ptl);
    tree.sample_bl_batch(sps, us, bl);
    tree.pmf_bl_batch(sps, which, pbl);
    CHECK(tree.try_sample_tl_batch(tps, us, tl).ok() && tree.try_pmf_tl_batch(tps, which, ptl).ok());
    CHECK(tree.try_sample_bl_batch(sps, us, bl).ok() && tree.try_pmf_bl_batch(sps, which, pbl).ok());
    for (std::size_t i = 0; i < n; i++) {
        ml_sampled_light s = tree.sample_tl(tps[i], us[i]);
        CHECK(s.light == tl[i].light && bits(s.pmf) == bits(tl[i].pmf));
        CHECK(s.light == ML_NO_LIGHT || bits(tree.pmf_tl(tps[i], s.light)) == bits(s.pmf));
        CHECK(bits(tree.pmf_tl(tps[i], which[i])) == bits(ptl[i]));
        ml_sampled_light sb = tree.sample_bl(sps[i], us[i]);
        CHECK(sb.light == bl[i].light && bits(sb.pmf) == bits(bl[i].pmf));
        CHECK(sb.light == ML_NO_LIGHT || bits(tree.pmf_bl(sps[i], sb.light)) == bits(sb.pmf));
        CHECK(bits(tree.pmf_bl(sps[i], which[i])) == bits(pbl[i]));
        CHECK(tree.try_sample_tl(tps[i], us[i]).ok() && tree.try_pmf_tl(tps[i], 0).ok());
        CHECK(tree.try_sample_bl(sps[i], us[i]).ok() && tree.try_pmf_bl(sps[i], 0).ok());
    }
    // The wrapper's span checks, and the library's element errors.
    std::vector<float> short_us(n - 1);
    ml::Result<void> bad = tree.try_sample_tl_batch(tps, short_us, tl);
    CHECK(bad.status() == ML_ERR_INVALID_ARGUMENT && contains(bad.message(), "us has 63 elements"));
    CHECK(throws<ml::Error>([&] { tree.sample_bl_batch(sps, us, ml::Span<ml_sampled_light>(bl.data(), 3)); }));
    us[5] = 1.0f;
    ml::Error e(ML_OK, "");
    CHECK(throws<ml::Error>([&] { tree.sample_tl_batch(tps, us, tl); }, &e));
    CHECK(e.status() == ML_ERR_INVALID_ARGUMENT && contains(e.what(), "us[5]"));
    ml::Result<float> out_of_range = tree.try_pmf_tl(tps[0], 7);
    CHECK(out_of_range.status() == ML_ERR_INVALID_ARGUMENT && contains(out_of_range.message(), "light"));

    // Points on lights: the batch equals the single calls.
    std::vector<ml_vec3> xs(n);
    std::vector<float> u0s(n), u1s(n);
    for (std::size_t i = 0; i < n; i++) {
        xs[i] = tps[i].position;
        u0s[i] = r.f32();
        u1s[i] = r.f32();
    }
    std::vector<ml_light_point> pts(n);
    tree.light_sample_point_batch(which, xs, u0s, u1s, pts);
    CHECK(tree.try_light_sample_point_batch(which, xs, u0s, u1s, pts).ok());
    for (std::size_t i = 0; i < n; i++) {
        ml_light_point p = tree.light_sample_point(which[i], xs[i], u0s[i], u1s[i]);
        CHECK(bits(p.pdf) == bits(pts[i].pdf) && bits(p.distance) == bits(pts[i].distance));
        CHECK(tree.try_light_sample_point(which[i], xs[i], u0s[i], u1s[i]).ok());
        if (p.pdf > 0 && !p.delta && which[i] == 2) {  // the sphere: its pdf at the point
            float q = tree.light_pdf_point(which[i], xs[i], p.position);
            CHECK(std::fabs(q - p.pdf) <= 1e-3f * p.pdf);
            CHECK(tree.try_light_pdf_point(which[i], xs[i], p.position).ok());
        }
    }
    CHECK(tree.try_light_sample_point_batch(which, xs, u0s, u1s, ml::Span<ml_light_point>()).status() ==
          ML_ERR_INVALID_ARGUMENT);

    // Serialization, loading, the parallel build (byte for byte the serial one).
    std::vector<uint8_t> bytes = tree.serialize();
    CHECK(bytes.size() == tree.serialized_size() && tree.try_serialized_size().ok());
    CHECK(tree.try_serialize().ok());
    std::vector<uint8_t> small(bytes.size() - 1);
    CHECK(tree.try_serialize(small).status() == ML_ERR_BUFFER_TOO_SMALL);
    CHECK(throws<ml::Error>([&] { (void)tree.serialize(small); }));
    std::vector<uint8_t> exact(bytes.size());
    CHECK(tree.serialize(exact) == bytes.size() && exact == bytes);
    ml::Tree loaded = ml::Tree::load(bytes);
    CHECK(loaded.stats().has_lights == 0 && ml::Tree::try_load(bytes).ok());
    ml::Tree with = ml::Tree::load_with_lights(bytes, ls);
    CHECK(with.stats().has_lights == 1 && ml::Tree::try_load_with_lights(bytes, ls).ok());
    CHECK(bits(with.sample_tl(tps[3], 0.25f).pmf) == bits(tree.sample_tl(tps[3], 0.25f).pmf));
    std::vector<uint8_t> corrupt = bytes;
    corrupt[corrupt.size() / 2] ^= 0xFF;
    CHECK(ml::Tree::try_load(corrupt).status() == ML_ERR_FORMAT);
    std::vector<ml_light> other = ls;
    other[4].triangle.radiance.r = 9;
    ml::Result<ml::Tree> mismatch = ml::Tree::try_load_with_lights(bytes, other);
    CHECK(mismatch.status() == ML_ERR_FORMAT && contains(mismatch.message(), "lights["));
    // A loaded tree has no lights: an estimator of it is ML_ERR_STATE.
    CHECK(ml::Estimator::try_create(loaded).status() == ML_ERR_STATE);
    ml::Tree par = ml::Tree::build_parallel(ls, 2);
    CHECK(par.serialize() == bytes && ml::Tree::try_build_parallel(ls, 1, nullptr).ok());
    CHECK(ml::Tree::try_build_parallel(ls, 5000).status() == ML_ERR_INVALID_ARGUMENT);
}

void cuts() {
    const std::vector<ml_light> ls = every_kind();
    const ml::Tree tree = ml::Tree::build(ls);
    ml::Cut cut = ml::Cut::create();
    CHECK(ml::Cut::try_create().ok());
    CHECK(cut.try_size().status() == ML_ERR_STATE);  // never built
    ml_shading_point sp = plane_point(0.3f, 0.2f, 0.5f);
    ml_bl_cut_options bo = ml::bl_cut_options();
    cut.build_bl(tree, sp, &bo);
    CHECK(cut.try_build_bl(tree, sp).ok());
    std::size_t n = cut.size();
    CHECK(n >= 1 && n <= ML_CUT_CAPACITY && cut.ib() >= 0 && cut.try_ib().ok());
    CHECK(cut.try_max_variance().status() == ML_ERR_STATE);
    ml_sampled_light s = cut.sample(0.4f);
    CHECK(s.light != ML_NO_LIGHT && bits(cut.pmf(s.light)) == bits(s.pmf));
    CHECK(cut.try_sample(0.4f).ok() && cut.try_pmf(s.light).ok());
    CHECK(cut.try_sample(1.5f).status() == ML_ERR_INVALID_ARGUMENT);
    std::vector<float> us(n, 0.5f);
    std::vector<ml_sampled_light> out(n);
    cut.sample_clusters(us, out);
    CHECK(cut.try_sample_clusters(us, out).ok());
    for (std::size_t i = 0; i < n; i++) {
        if (out[i].light == ML_NO_LIGHT) continue;
        ml::ClusterPmf c = cut.pmf_in(out[i].light);
        CHECK(c.cluster == i && bits(c.pmf) == bits(out[i].pmf));
        CHECK(cut.try_pmf_in(out[i].light).ok());
    }
    std::vector<ml_sampled_light> fewer(n + 1);
    CHECK(cut.try_sample_clusters(us, fewer).status() == ML_ERR_INVALID_ARGUMENT);
    ml_tl_point tp{{0.3f, 0.2f, 0}, {0, 0, 1}, ML_RECEIVER_REFLECTIVE};
    ml_split_cut_options so = ml::split_cut_options();
    cut.build_split(tree, tp, &so);
    CHECK(cut.try_build_split(tree, tp).ok());
    CHECK(cut.max_variance() >= 0 && cut.try_ib().status() == ML_ERR_STATE);
    tp.receiver = 9;
    ml::Result<void> bad = cut.try_build_split(tree, tp);
    CHECK(bad.status() == ML_ERR_INVALID_ARGUMENT && contains(bad.message(), "receiver"));
    CHECK(throws<ml::Error>([&] { cut.build_split(tree, tp); }));
}

// One point light of intensity I at height h over a Lambert plane of albedo rho: the
// reflected radiance at the foot point is rho/π · I / h², whatever the technique (no BSDF ray
// reaches a point light, so each estimate is exact up to rounding).
void estimates() {
    const float I = 3, h = 2, rho = 0.5f;
    const double exact = rho / kPi * I / (h * h);
    const std::vector<ml_light> ls{ml::point_light({0, 0, h}, {I, I, I})};
    const ml::Tree tree = ml::Tree::build(ls);
    ml::Estimator est = ml::Estimator::create(tree);
    CHECK(ml::Estimator::try_create(tree).ok());
    const ml_shading_point sp = plane_point(0, 0, rho);
    Rng r{5};
    auto f32 = [&r] { return r.f32(); };
    auto u32 = ml::uniforms(f32);
    auto u64 = ml::uniforms([&r] { return r.f32(); }, [&r] { return r.f64(); });
    ml_direct_params params = ml::direct_params();
    est.set_point(sp, ML_TECHNIQUE_BL_MIS, &params);
    CHECK(est.try_set_point(sp, ML_TECHNIQUE_BL_MIS).ok());
    ml_rgb64 e = est.estimate(ml::unoccluded(), u32);
    CHECK(std::fabs(e.g - exact) <= 1e-5 * exact && e.r == e.b);
    CHECK(est.try_estimate(ml::unoccluded(), u64).ok());
    // Shadow rays and first-surface distances: occluded by a surface at distance 1 < h.
    long shadow_calls = 0;
    auto blocked = [&shadow_calls](ml_vec3, ml_vec3, float t) {
        ++shadow_calls;
        return t > 1;
    };
    e = est.estimate(ml::shadow_rays(blocked), u64);
    CHECK(e.g == 0 && shadow_calls > 0);
    e = est.estimate(ml::first_hit([](ml_vec3, ml_vec3) { return 1.0f; }), u64);
    CHECK(e.g == 0);
    e = est.estimate(ml::first_hit([](ml_vec3, ml_vec3) { return INFINITY; }), u64);
    CHECK(std::fabs(e.g - exact) <= 1e-5 * exact);
    // The wrappers' C structs: a reference to an lvalue callable, no next_f64 without one.
    auto never = [](ml_vec3, ml_vec3, float) { return false; };
    ml::ShadowRays<decltype(never) &> sr = ml::shadow_rays(never);
    CHECK(sr.c().occluded != nullptr && sr.c().first_hit == nullptr && sr.c().user_data == &never);
    auto far = [](ml_vec3, ml_vec3) { return INFINITY; };
    ml::FirstHit<decltype(far) &> fh = ml::first_hit(far);
    CHECK(fh.c().occluded == nullptr && fh.c().first_hit != nullptr);
    ml::Uniforms<decltype(f32) &, std::nullptr_t> uf = ml::uniforms(f32);
    CHECK(uf.c().next_f32 != nullptr && uf.c().next_f64 == nullptr && u64.c().next_f64 != nullptr);
    ml::Unoccluded nothing = ml::unoccluded();
    e = est.estimate(nothing, uf);
    CHECK(std::fabs(e.g - exact) <= 1e-5 * exact);
    // The C structs themselves.
    const ml_visibility none{nullptr, nullptr, nullptr};
    const ml_uniforms cu{[](void *u) { return static_cast<Rng *>(u)->f32(); }, nullptr, &r};
    e = est.estimate(none, cu);
    CHECK(std::fabs(e.g - exact) <= 1e-5 * exact);
    // The one call and its batch equal the estimator with the same numbers, bit for bit.
    Rng r1{77}, r2{77}, r3{77};
    ml_rgb64 one = tree.direct_estimate(sp, ML_TECHNIQUE_TL_MIS, nullptr, ml::unoccluded(),
                                        ml::uniforms([&r1] { return r1.f32(); }));
    CHECK(tree.try_direct_estimate(sp, ML_TECHNIQUE_TL_MIS, nullptr, ml::unoccluded(), u32).ok());
    est.set_point(sp, ML_TECHNIQUE_TL_MIS);
    ml_rgb64 two = est.estimate(ml::unoccluded(), ml::uniforms([&r2] { return r2.f32(); }));
    CHECK(one.r == two.r && one.g == two.g && one.b == two.b);
    std::vector<ml_shading_point> pts{sp, plane_point(0.5f, 0, rho)};
    std::vector<ml_rgb64> out(4);
    tree.direct_estimate_batch(pts, 2, ML_TECHNIQUE_TL_MIS, nullptr, ml::unoccluded(),
                               ml::uniforms([&r3] { return r3.f32(); }), out);
    CHECK(out[0].g == one.g);
    CHECK(tree.try_direct_estimate_batch(pts, 2, ML_TECHNIQUE_TL_MIS, nullptr, ml::unoccluded(),
                                         u32, out)
              .ok());
    ml::Result<void> short_out = tree.try_direct_estimate_batch(
        pts, 3, ML_TECHNIQUE_TL_MIS, nullptr, ml::unoccluded(), u32, out);
    CHECK(short_out.status() == ML_ERR_INVALID_ARGUMENT && contains(short_out.message(), "out has 4"));
    // Bad input through the wrapper: the library's message names the field.
    ml_shading_point bad = sp;
    bad.material.alpha = 2;
    bad.material.kind = ML_MATERIAL_KIND_GGX;
    ml::Error err(ML_OK, "");
    CHECK(throws<ml::Error>([&] { est.set_point(bad, ML_TECHNIQUE_BL_MIS); }, &err));
    CHECK(err.status() == ML_ERR_INVALID_ARGUMENT && contains(err.what(), "alpha"));
    CHECK(throws<ml::Error>([&] {
        (void)tree.direct_estimate(sp, 99, nullptr, ml::unoccluded(), u32);
    }));
    CHECK(est.try_estimate(ml::unoccluded(), ml::uniforms([] { return 1.0f; })).status() ==
          ML_ERR_INVALID_ARGUMENT);
}

// The lower level with a host Lambert BSDF on a sphere light: the step loop's mean against
// the one call's mean (both unbiased estimates of the same radiance), within 5 standard errors.
void lower_level() {
    const float rho = 0.6f;
    const std::vector<ml_light> ls{ml::sphere_light({0, 0, 2}, 1.0f, {1, 1, 1})};
    const ml::Tree tree = ml::Tree::build(ls);
    ml::Estimator est = ml::Estimator::create(tree);
    const ml_shading_point sp = plane_point(0, 0, rho);
    est.set_point(sp, ML_TECHNIQUE_TL_MIS);
    Rng r{314};
    auto u = ml::uniforms([&r] { return r.f32(); });
    const float f = rho / kPi;
    const int n = 4000;
    double sum = 0, sum2 = 0;
    long hits = 0, light_steps = 0, bsdf_steps = 0;
    for (int i = 0; i < n; i++) {
        double v = 0;
        est.start();
        for (;;) {
            ml_step s = est.next(u);
            if (s.kind == ML_STEP_KIND_DONE) break;
            if (s.kind == ML_STEP_KIND_LIGHT) {
                ++light_steps;
                float c = s.point.direction.z;
                if (c <= 0 || s.point.pdf <= 0) continue;
                ml_weighted w = est.weigh(s.needs_bsdf_pdf ? c / kPi : 0);
                v += static_cast<double>(f) * s.point.radiance.g * c * w.scale;
            } else {
                ++bsdf_steps;
                float rr = std::sqrt(s.u0), phi = 2 * kPi * s.u1;
                float z = std::sqrt(1 - s.u0 > 0 ? 1 - s.u0 : 0);
                if (z <= 0) continue;
                ml_vec3 wi{rr * std::cos(phi), rr * std::sin(phi), z};
                bool any = est.bsdf_hits(wi, z / kPi, INFINITY, [&](const ml_light_hit &hit) {
                    ++hits;
                    v += static_cast<double>(f) * hit.point.radiance.g * z * hit.weighted.scale;
                });
                (void)any;
            }
        }
        sum += v;
        sum2 += v * v;
    }
    CHECK(light_steps > 0 && bsdf_steps > 0 && hits > 0);
    // The sphere of radius R at height h seen from its foot: E = π L sin²θ, sin θ = R/h.
    const double exact = rho * 1.0 * (1.0 / 4.0);
    double mean = sum / n, var = (sum2 - n * mean * mean) / (n - 1);
    CHECK(std::fabs(mean - exact) <= 5 * std::sqrt(var / n));
    // The non-throwing forms, and their errors out of order.
    CHECK(est.try_start().ok() && est.try_next(u).ok());
    CHECK(est.try_start().ok());
    CHECK(est.try_weigh(1).status() == ML_ERR_STATE);
    uint32_t calls = 0;
    ml::Result<bool> no_step = est.try_bsdf_hits({0, 0, 1}, 1, INFINITY, [&](const ml_light_hit &) { ++calls; });
    CHECK(no_step.status() == ML_ERR_STATE && calls == 0);
}

// Learned visibility: half the lights behind a wall (+x blocked), learned in passes with
// commits; the estimate stays within 5 standard errors of the closed form.
void visibility_caches() {
    const float rho = 0.5f;
    std::vector<ml_light> ls;
    for (int i = 0; i < 16; i++) {
        const float x = (i % 4) - 1.5f, y = (i / 4) - 1.5f;
        ls.push_back(ml::point_light({x, y, 2.0f}, {1, 1, 1}));
    }
    const ml::Tree tree = ml::Tree::build(ls);
    ml_visibility_cache_options o = ml::VisibilityCache::options(1.0f);
    CHECK(ml::VisibilityCache::try_options(1.0f).ok());
    // Options are checked when a cache is made from them.
    ml::Result<ml::VisibilityCache> r0 =
        ml::VisibilityCache::try_create(tree, ml::VisibilityCache::try_options(0.0f).value());
    CHECK(r0.status() == ML_ERR_INVALID_ARGUMENT && contains(r0.message(), "cell_size"));
    o.cells = 16;
    o.slots = 64;
    ml::VisibilityCache cache = ml::VisibilityCache::create(tree, o);
    CHECK(ml::VisibilityCache::try_create(tree, o).ok());
    ml_visibility_cache_options bad = o;
    bad.floor = 2.0f;
    ml::Result<ml::VisibilityCache> rb = ml::VisibilityCache::try_create(tree, bad);
    CHECK(rb.status() == ML_ERR_INVALID_ARGUMENT && contains(rb.message(), "floor"));
    CHECK(cache.bytes() == 16u * (64u * 17u + 1u) && cache.try_bytes().ok());
    ml::Estimator est = ml::Estimator::create(tree);
    est.set_visibility_cache(&cache);
    CHECK(est.try_set_visibility_cache(&cache).ok());
    const ml_shading_point sp = plane_point(0, 0, rho);
    Rng r{27};
    auto u = ml::uniforms([&r] { return r.f32(); });
    auto wall = ml::shadow_rays([](ml_vec3, ml_vec3 d, float) { return d.x > 0; });
    // The exact value: each unblocked point light's ρ/π · I cos θ / d².
    double exact = 0;
    for (const ml_light &l : ls) {
        const ml_vec3 p = l.point.position;
        const double d2 = double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z;
        if (p.x <= 0) exact += rho / kPi * 1.0 * (p.z / std::sqrt(d2)) / d2;
    }
    double sum = 0, sum2 = 0;
    const int n = 3000;
    for (int pass = 0; pass < 4; pass++) {
        est.set_point(sp, ML_TECHNIQUE_BL_MIS);
        for (int i = 0; i < n / 4; i++) {
            const double v = est.estimate(wall, u).g;
            sum += v;
            sum2 += v * v;
        }
        if (pass == 1) {
            // The lower level records its own shadow rays.
            est.start();
            for (;;) {
                ml_step s = est.next(u);
                if (s.kind == ML_STEP_KIND_DONE) break;
                if (s.kind == ML_STEP_KIND_LIGHT) {
                    est.record(s.point.direction.x <= 0);
                    CHECK(est.try_record(true).ok());
                }
            }
        }
        cache.commit();
    }
    CHECK(cache.try_commit().ok());
    const ml_visibility_cache_counts c = cache.stats();
    CHECK(c.samples > 0 && c.visible > 0 && c.visible < c.samples && cache.try_stats().ok());
    const double mean = sum / n, var = (sum2 - n * mean * mean) / (n - 1);
    CHECK(std::fabs(mean - exact) <= 5 * std::sqrt(var / n));
    cache.set_recording(false);
    CHECK(cache.try_set_recording(true).ok());
    cache.clear();
    CHECK(cache.try_clear().ok() && cache.stats().samples == 0);
    est.set_visibility_cache(nullptr);
    ml::VisibilityCache moved = std::move(cache);
    CHECK(!cache && moved);
}

struct Boom : std::runtime_error {
    Boom() : std::runtime_error("boom") {}
};

// Exceptions thrown by callables cross no C frame: rethrown after the call, from both forms;
// the callable is not called again during that call, and the next call works.
void callback_exceptions() {
    const std::vector<ml_light> ls{ml::sphere_light({0, 0, 2}, 1.0f, {1, 1, 1})};
    const ml::Tree tree = ml::Tree::build(ls);
    ml::Estimator est = ml::Estimator::create(tree);
    const ml_shading_point sp = plane_point(0, 0, 0.5f);
    est.set_point(sp, ML_TECHNIQUE_MIS_EQUAL);
    Rng r{1};
    int calls = 0;
    auto throwing = ml::uniforms([&] () -> float {
        ++calls;
        throw Boom();
    });
    CHECK(throws<Boom>([&] { (void)est.estimate(ml::unoccluded(), throwing); }));
    CHECK(calls == 1);
    CHECK(throws<Boom>([&] { (void)est.try_estimate(ml::unoccluded(), throwing); }));
    CHECK(calls == 2);
    auto good = ml::uniforms([&r] { return r.f32(); });
    CHECK(est.try_estimate(ml::unoccluded(), good).ok());
    int shadows = 0;
    CHECK(throws<std::logic_error>([&] {
        (void)est.estimate(ml::shadow_rays([&](ml_vec3, ml_vec3, float) -> bool {
                               ++shadows;
                               throw std::logic_error("occluder");
                           }),
                           good);
    }));
    CHECK(shadows == 1);
    CHECK(throws<Boom>([&] {
        (void)tree.direct_estimate(sp, ML_TECHNIQUE_TL, nullptr,
                                   ml::first_hit([](ml_vec3, ml_vec3) -> float { throw Boom(); }), good);
    }));
    // A hit callable that throws (tl-mis takes a BSDF sample at a Lambert point).
    est.set_point(sp, ML_TECHNIQUE_TL_MIS);
    bool thrown = false;
    for (int i = 0; i < 200 && !thrown; i++) {
        est.start();
        for (;;) {
            ml_step s = est.next(good);
            if (s.kind == ML_STEP_KIND_DONE) break;
            if (s.kind != ML_STEP_KIND_BSDF) continue;
            thrown = throws<Boom>([&] {
                (void)est.bsdf_hits({0, 0, 1}, 1 / kPi, INFINITY,
                                    [](const ml_light_hit &) { throw Boom(); });
            });
            break;
        }
    }
    CHECK(thrown);
    // A VPL visibility callable that throws.
    ml::Acceptor acc = ml::Acceptor::create(ml::acceptor_options(16, 4));
    ml_importon imp{};
    imp.hit = 1;
    imp.position = {0, 0, 0};
    imp.normal = {0, 0, 1};
    imp.wo = {0, 0, 1};
    imp.material = ml::lambert({0.5f, 0.5f, 0.5f});
    std::vector<ml_importon> imps(4, imp);
    acc.set_importons(imps);
    acc.set_total_luminance(10);
    const ml_vpl c{{0, 0, 1}, {0, 0, -1}, {1, 1, 1}};
    CHECK(throws<Boom>([&] {
        (void)acc.probability(c, [](ml_vec3, ml_vec3) -> bool { throw Boom(); });
    }));
    CHECK(acc.try_probability(c).ok());
}

// A uniform environment of radiance L over a Lambert plane: the estimate's mean is ρ·L within
// 5 standard errors; the callables live as long as anything made from the tree.
void environment() {
    const float L = 0.5f, rho = 0.6f;
    const float y = kPi * L * 1.0001f;
    long samples = 0;
    ml::Environment sky = ml::environment(
        [&samples, L](float u0, float u1, ml_vec3 &d, ml_rgb &radiance, float &pdf) {
            ++samples;
            float z = 1 - 2 * u0, s = std::sqrt(std::fmax(0.0f, 1 - z * z)), phi = 2 * kPi * u1;
            d = {s * std::cos(phi), s * std::sin(phi), z};
            radiance = {L, L, L};
            pdf = 1 / (4 * kPi);
            return true;
        },
        [L](ml_vec3, ml_rgb &radiance, float &pdf) {
            radiance = {L, L, L};
            pdf = 1 / (4 * kPi);
        },
        {{y, y, y, y, y, y}});
    CHECK(sky.c().sample != nullptr && sky.keep_alive() != nullptr);
    ml::Estimator est;
    std::vector<uint8_t> bytes;
    {
        // The tree goes first: the estimator keeps it and its environment.
        ml::Tree tree = ml::Tree::build(ml::Span<const ml_light>(), sky);
        CHECK(tree.stats().lights == 1 && tree.keep_alive() == sky.keep_alive());
        CHECK(ml::Tree::try_build(ml::Span<const ml_light>(), sky, nullptr).ok());
        bytes = tree.serialize();
        est = ml::Estimator::create(tree);
        ml_light_point p = tree.light_sample_point(0, {0, 0, 0}, 0.3f, 0.6f);
        CHECK(std::isinf(p.distance) && p.radiance.g == L && p.pdf == 1 / (4 * kPi));
        CHECK(tree.light_pdf_point(0, {0, 0, 0}, p.position) == 1 / (4 * kPi));
    }
    sky = ml::environment([](float, float, ml_vec3 &, ml_rgb &, float &) { return false; },
                          [](ml_vec3, ml_rgb &, float &) {}, {{0, 0, 0, 0, 0, 0}});
    const ml_shading_point sp = plane_point(0, 0, rho);
    est.set_point(sp, ML_TECHNIQUE_TL_MIS);
    Rng r{2718};
    auto u = ml::uniforms([&r] { return r.f32(); }, [&r] { return r.f64(); });
    const int n = 4000;
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; i++) {
        double v = est.estimate(ml::unoccluded(), u).g;
        sum += v;
        sum2 += v * v;
    }
    double mean = sum / n, var = (sum2 - n * mean * mean) / (n - 1);
    CHECK(samples > 0 && std::fabs(mean - rho * L) <= 5 * std::sqrt(var / n) + 1e-7);

    // Loading and the parallel build with an environment; a throwing environment.
    auto throwing = ml::environment(
        [](float, float, ml_vec3 &, ml_rgb &, float &) -> bool { throw Boom(); },
        [](ml_vec3, ml_rgb &, float &) { throw Boom(); }, {{y, y, y, y, y, y}});
    ml::Tree loaded = ml::Tree::load_with_lights(bytes, ml::Span<const ml_light>(), throwing);
    CHECK(ml::Tree::try_load_with_lights(bytes, ml::Span<const ml_light>(), throwing).ok());
    CHECK(throws<Boom>([&] { (void)loaded.light_sample_point(0, {0, 0, 0}, 0.5f, 0.5f); }));
    CHECK(throws<Boom>([&] { (void)loaded.try_light_pdf_point(0, {0, 0, 0}, {0, 0, 1}); }));
    std::vector<uint32_t> zero{0};
    std::vector<ml_vec3> xs{{0, 0, 0}};
    std::vector<float> half{0.5f};
    std::vector<ml_light_point> pts(1);
    CHECK(throws<Boom>([&] { loaded.light_sample_point_batch(zero, xs, half, half, pts); }));
    ml::Tree par = ml::Tree::build_parallel(ml::Span<const ml_light>(), throwing, 2);
    CHECK(par.serialize() == bytes);
    CHECK(ml::Tree::try_build_parallel(ml::Span<const ml_light>(), throwing, 2, nullptr).ok());
    ml::Estimator e2 = ml::Estimator::create(par);
    e2.set_point(sp, ML_TECHNIQUE_TL_MIS);
    CHECK(throws<Boom>([&] { (void)e2.estimate(ml::unoccluded(), u); }));
    // A C environment wrapped as it is.
    ml::Environment c_env(throwing.c());
    CHECK(c_env.keep_alive() == nullptr && c_env.c().user_data == throwing.c().user_data);
    // Bad bounds: the library names the field.
    auto bad = ml::environment([](float, float, ml_vec3 &, ml_rgb &, float &) { return false; },
                               [](ml_vec3, ml_rgb &, float &) {}, {{-1, 0, 0, 0, 0, 0}});
    ml::Result<ml::Tree> r_bad = ml::Tree::try_build(ml::Span<const ml_light>(), bad);
    CHECK(r_bad.status() == ML_ERR_INVALID_ARGUMENT &&
          contains(r_bad.message(), "irradiance_bounds"));
}

void brdfs() {
    ml_shading_point sp = plane_point(0, 0, 0.5f);
    ml_rgb f = ml::brdf_eval(sp, {0, 0, 1});
    CHECK(std::fabs(f.r - 0.5f / kPi) <= 1e-6f && ml::try_brdf_eval(sp, {0, 0, 1}).ok());
    ml_brdf_draw d = ml::brdf_sample(sp, 0.3f, 0.7f);
    CHECK(d.pdf > 0 && ml::try_brdf_sample(sp, 0.3f, 0.7f).ok());
    float p = ml::brdf_pdf(sp, d.wi);
    CHECK(std::fabs(p - d.pdf) <= 1e-4f * d.pdf && ml::try_brdf_pdf(sp, d.wi).ok());
    ml::Result<ml_rgb> bad = ml::try_brdf_eval(sp, {0, 0, 0});
    CHECK(bad.status() == ML_ERR_INVALID_ARGUMENT && contains(bad.message(), "wi"));
    CHECK(throws<ml::Error>([&] { (void)ml::brdf_sample(sp, 1.0f, 0.0f); }));
    CHECK(throws<ml::Error>([&] { (void)ml::brdf_pdf(sp, {NAN, 0, 1}); }));
}

void vpls() {
    ml::Result<ml::Acceptor> none = ml::Acceptor::try_create(ml::acceptor_options(0, 4));
    CHECK(none.status() == ML_ERR_INVALID_ARGUMENT && contains(none.message(), "pixels"));
    ml::Acceptor acc = ml::Acceptor::create(ml::acceptor_options(64, 8));
    std::vector<ml_importon> imps(10);
    for (std::size_t i = 0; i < imps.size(); i++) {
        imps[i].hit = 1;
        imps[i].position = {static_cast<float>(i) * 0.1f, 0, 0};
        imps[i].normal = {0, 0, 1};
        imps[i].wo = {0, 0, 1};
        imps[i].material = ml::lambert({0.5f, 0.5f, 0.5f});
    }
    acc.set_importons(imps);
    CHECK(acc.try_set_importons(imps).ok());
    const ml_vpl c{{0, 0, 1}, {0, 0, -1}, {1, 1, 1}};
    ml_vpl_decision d = acc.accept(c, 0.5f);  // Φ̃_total = 0: every candidate kept
    CHECK(d.accepted == 1 && d.probability == 1 && acc.try_accept(c, 0.5f).ok());
    acc.update(50);
    CHECK(acc.try_update(50).ok());
    acc.set_total_luminance(1e4);
    CHECK(acc.try_set_total_luminance(1e4).ok());
    long visible_calls = 0;
    auto visible = [&visible_calls](ml_vec3, ml_vec3) {
        ++visible_calls;
        return true;
    };
    float p0 = acc.probability(c);
    float p1 = acc.probability(c, visible);
    CHECK(p0 > 0 && p0 <= 1 && p0 == p1 && visible_calls > 0);
    CHECK(acc.try_probability(c, visible).ok());
    ml_vpl_decision d1 = acc.accept(c, 0.0f, visible);
    CHECK(d1.accepted == 1 && acc.try_accept(c, 0.0f, visible).ok());
    ml_accept_stats st = acc.stats();
    CHECK(st.candidates == 4 && acc.try_stats().ok());
    acc.reset_stats();
    CHECK(acc.stats().candidates == 0);
    CHECK(acc.try_update(-1).status() == ML_ERR_INVALID_ARGUMENT);
    CHECK(throws<ml::Error>([&] { acc.set_total_luminance(NAN); }));
    ml_vpl bad = c;
    bad.intensity.g = -1;
    ml::Result<ml_vpl_decision> rb = acc.try_accept(bad, 0.5f);
    CHECK(rb.status() == ML_ERR_INVALID_ARGUMENT && contains(rb.message(), "intensity"));
}

}  // namespace

int main() {
    values();
    spans();
    errors_and_moves();
    tree_queries();
    cuts();
    estimates();
    lower_level();
    visibility_caches();
    callback_exceptions();
    environment();
    brdfs();
    vpls();
    std::printf("test_hpp: %d checks, %d failures\n", g_checks, g_failures);
    return g_failures == 0 ? 0 : 1;
}
