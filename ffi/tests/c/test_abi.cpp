// The C ABI from C++17: the scenarios of test_abi.c compiled as C++ (the header's extern "C"
// guards), with the tree held by a std::unique_ptr, std::thread workers sharing it, and the
// batch calls driven from std::vector.
//
// Usage: test_abi_cpp DUMP_PATH
#include "scenarios.h"
#include "visibility_cache.h"

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <thread>
#include <vector>

namespace {

struct TreeDeleter {
    void operator()(ml_tree *t) const { ml_tree_free(t); }
};
using Tree = std::unique_ptr<ml_tree, TreeDeleter>;

// The batch path from std::vector, compared with the single calls.
void vector_batches(const ml_tree *tree) {
    rng r{99};
    std::vector<ml_tl_point> points(1000);
    std::vector<float> us(points.size());
    for (std::size_t i = 0; i < points.size(); i++) {
        points[i] = make_tl_point(&r);
        us[i] = rng_f32(&r);
    }
    std::vector<ml_sampled_light> out(points.size());
    OK(ml_tree_sample_tl_batch(tree, points.data(), us.data(), points.size(), out.data()));
    for (std::size_t i = 0; i < points.size(); i++) {
        ml_sampled_light s{};
        OK(ml_tree_sample_tl(tree, &points[i], us[i], &s));
        CHECK(s.light == out[i].light && bits(s.pmf) == bits(out[i].pmf));
    }
}

}  // namespace

int main(int argc, char **argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s DUMP_PATH\n", argv[0]);
        return 2;
    }
    const std::size_t n = 10000;
    std::unique_ptr<ml_light, void (*)(void *)> lights(make_lights(n, 2024), std::free);
    Tree tree(build_tree(lights.get(), n));
    if (!tree) return 1;

    std::vector<sample_job> jobs(2);
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < jobs.size(); i++) {
        jobs[i] = sample_job{tree.get(), 3000 + i, 1024, 0, 0.0};
        threads.emplace_back(sample_job_run, &jobs[i]);
    }
    for (auto &t : threads) t.join();
    for (const auto &j : jobs) {
        g_failures += j.failures;
        CHECK(j.checksum > 0);
    }

    vector_batches(tree.get());
    dump_consistency(argv[1], tree.get(), lights.get(), n);
    scenario_tree(tree.get(), n);
    scenario_cache(tree.get(), lights.get(), n);
    scenario_cut(tree.get(), n);
    scenario_cut_infinite();
    scenario_narrow_sun();
    scenario_points(tree.get(), lights.get(), n);
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
    scenario_bad_input(tree.get(), n);

    tree.reset();
    print_coverage();
    std::printf("%s: %d failures\n", argv[0], g_failures);
    return g_failures == 0 ? 0 : 1;
}
