/**
 * @file manylights.hpp
 * @brief A header-only C++17 wrapper of the C ABI `manylights.h` (namespace `ml`).
 *
 * Written by hand over the generated C header, which it includes; it adds no symbol to the
 * library and links against the same `libmanylights` (shared or static). The C structs
 * (`ml_vec3`, `ml_rgb`, `ml_light`, `ml_shading_point`, `ml_tl_point`, ...) are used as they
 * are; what the wrapper adds:
 *
 * - **Handles**: `ml::Tree` (`ml_tree`), `ml::Estimator` (`ml_estimator`), `ml::Cut`
 *   (`ml_cut`) and `ml::Acceptor` (`ml_acceptor`) own their C handle and free it in their
 *   destructor. They are move-only: a moved-from handle is empty (`!h`, `h.get() == nullptr`)
 *   and its destructor does nothing. A default-constructed handle is empty too; calling a
 *   method on an empty handle fails with `ML_ERR_NULL`. `get()` gives the C handle for the C
 *   functions (still owned by the wrapper).
 * - **Errors, one pattern everywhere**: every fallible call `f(...)` throws `ml::Error` (a
 *   `std::runtime_error` carrying the `ml_status` and the library's message, e.g.
 *   `ml_tree_build: lights[17].sphere.radius must be positive (got -1)`), and has a
 *   non-throwing twin `try_f(...)` with the same arguments returning `ml::Result<T>`:
 *   `ok()`, `status()`, `message()` and `value()` (which throws the `ml::Error` when not ok).
 *   The wrapper's own checks (spans of different lengths) fail the same way, with
 *   `ML_ERR_INVALID_ARGUMENT` and a message naming the span. Calls that cannot fail (the
 *   `*_default` options, `ml::version`, `ml::status_name`) return their value directly.
 * - **Spans**: `ml::Span<T>` (pointer and size, like C++20's `std::span`) for batches, made
 *   from a `std::vector`, a `std::array`, a C array or a pointer and a count.
 * - **Callbacks as callables**: shadow rays, first-surface distances, uniform numbers, BSDF
 *   hits, VPL visibility and the environment are any callables (lambdas, function objects,
 *   function pointers). The wrapper passes the C library a static trampoline and a pointer to
 *   the callable as `user_data`. An lvalue callable is referred to (it must outlive the
 *   call, or for the environment the tree); an rvalue callable is moved into the wrapper
 *   object. **Exceptions never cross the C boundary**: a trampoline catches whatever the
 *   callable throws, stores it (per thread), returns a neutral value to the library (no
 *   occluder, no hit, no sample, 0 as the uniform number, zero radiance) and calls the
 *   callable no more during that call; once the C call has returned, the wrapper rethrows
 *   the stored exception, from the throwing and the `try_` form alike (it is the host's own,
 *   not a library error), and the call's outputs are discarded.
 * - **Lights and materials**: `ml::point_light(...)`, `ml::sphere_light(...)`, ...,
 *   `ml::lambert(...)`, `ml::plastic(...)` fill the C union `ml_light` / `ml_material`.
 *
 * Threads follow the C ABI: an `ml::Tree` is immutable and its `const` methods may be called
 * from any number of threads at once; an `ml::Estimator`, `ml::Cut` or `ml::Acceptor` is
 * used by one thread at a time (one per thread). Callables passed to a call are called on the
 * calling thread during the call only; the environment's are kept by the tree and called
 * from every thread that uses it, at once (they must be safe to call concurrently).
 *
 * Arguments follow the C functions' order; a C input pointer becomes a reference, a C input
 * pointer that may be NULL (options, parameters: NULL for the defaults) stays a pointer
 * defaulting to `nullptr`, and C out-params become the return value.
 */
#ifndef MANYLIGHTS_HPP
#define MANYLIGHTS_HPP

#include "manylights.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace ml {

// ---- errors --------------------------------------------------------------------------

/** The name of a status code (`"ML_OK"`, `"ML_ERR_NULL"`, ...; `"unknown"` for others). */
[[nodiscard]] inline const char *status_name(ml_status status) noexcept {
    const char *name = "unknown";
    if (ml_status_name(status, &name) != ML_OK) return "unknown";
    return name;
}

/**
 * A failed call: the `ml_status` (never `ML_OK`) and the library's message, which names the
 * function, the argument, the element or light index and the field (`what()`).
 */
class Error : public std::runtime_error {
  public:
    /** An error of `status` with `message`. */
    Error(ml_status status, const std::string &message)
        : std::runtime_error(message), status_(status) {}
    /** The status code (`ML_ERR_*`). */
    [[nodiscard]] ml_status status() const noexcept { return status_; }
    /** The status code's name (`"ML_ERR_INVALID_ARGUMENT"`, ...). */
    [[nodiscard]] const char *status_name() const noexcept { return ml::status_name(status_); }

  private:
    ml_status status_;
};

/**
 * The outcome of a `try_` call: a value of type `T`, or a status and its message. `T` is
 * `void` for calls without a result.
 */
template <class T>
class [[nodiscard]] Result {
  public:
    /** Success with `value`. */
    Result(T value) : value_(std::move(value)), status_(ML_OK) {}  // NOLINT: implicit on purpose
    /** Failure with `status` (not `ML_OK`) and `message`. */
    Result(ml_status status, std::string message)
        : status_(status), message_(std::move(message)) {}

    /** True on success. */
    [[nodiscard]] bool ok() const noexcept { return status_ == ML_OK; }
    /** True on success. */
    explicit operator bool() const noexcept { return ok(); }
    /** `ML_OK` or the error's status. */
    [[nodiscard]] ml_status status() const noexcept { return status_; }
    /** The error's message (`""` on success). */
    [[nodiscard]] const std::string &message() const noexcept { return message_; }
    /** The value; throws the `ml::Error` if the call failed. */
    T &value() & {
        check();
        return *value_;
    }
    /** The value; throws the `ml::Error` if the call failed. */
    const T &value() const & {
        check();
        return *value_;
    }
    /** The value, moved out; throws the `ml::Error` if the call failed. */
    T &&value() && {
        check();
        return std::move(*value_);
    }

  private:
    void check() const {
        if (!ok()) throw Error(status_, message_);
    }
    std::optional<T> value_;
    ml_status status_;
    std::string message_;
};

/** The outcome of a `try_` call without a result. */
template <>
class [[nodiscard]] Result<void> {
  public:
    /** Success. */
    Result() : status_(ML_OK) {}
    /** Failure with `status` and `message`. */
    Result(ml_status status, std::string message)
        : status_(status), message_(std::move(message)) {}
    /** True on success. */
    [[nodiscard]] bool ok() const noexcept { return status_ == ML_OK; }
    /** True on success. */
    explicit operator bool() const noexcept { return ok(); }
    /** `ML_OK` or the error's status. */
    [[nodiscard]] ml_status status() const noexcept { return status_; }
    /** The error's message (`""` on success). */
    [[nodiscard]] const std::string &message() const noexcept { return message_; }
    /** Throws the `ml::Error` if the call failed. */
    void value() const {
        if (!ok()) throw Error(status_, message_);
    }

  private:
    ml_status status_;
    std::string message_;
};

namespace detail {

/** The failed `Result` of a C call's status, with this thread's last message. */
template <class T>
Result<T> failure(ml_status status) {
    return Result<T>(status, std::string(ml_last_error_message()));
}

/**
 * `value` on `ML_OK`, else the failure. The C call is made before, in a statement of its
 * own: as an argument beside `value` it could run after `value` was copied (the order in
 * which arguments are evaluated is unspecified).
 */
template <class T>
Result<T> result(ml_status status, T value) {
    if (status != ML_OK) return failure<T>(status);
    return Result<T>(std::move(value));
}

inline Result<void> result(ml_status status) {
    if (status != ML_OK) return failure<void>(status);
    return Result<void>();
}

/** A failure the wrapper itself finds (spans of different lengths). */
template <class T>
Result<T> invalid(const char *function, const char *span, std::size_t got, const char *other,
                  std::size_t want) {
    return Result<T>(ML_ERR_INVALID_ARGUMENT,
                     std::string(function) + ": " + span + " has " + std::to_string(got) +
                         " elements, " + other + " " + std::to_string(want));
}

/** This thread's exception thrown by a callable during a C call, not yet rethrown. */
inline std::exception_ptr &pending() noexcept {
    static thread_local std::exception_ptr p;
    return p;
}

/**
 * Brackets a C call that may call the host's callables: clears the thread's pending
 * exception (keeping an enclosing call's) and, in `finish`, rethrows one a callable threw.
 */
class CallScope {
  public:
    CallScope() noexcept : outer_(std::exchange(pending(), nullptr)) {}
    CallScope(const CallScope &) = delete;
    CallScope &operator=(const CallScope &) = delete;
    ~CallScope() {
        if (!finished_) pending() = std::move(outer_);
    }
    /** Rethrows the exception a callable threw during the call, if any. */
    void finish() {
        finished_ = true;
        std::exception_ptr mine = std::exchange(pending(), std::move(outer_));
        if (mine) std::rethrow_exception(mine);
    }

  private:
    std::exception_ptr outer_;
    bool finished_ = false;
};

/**
 * Runs the host's callable `body` inside a trampoline: `fallback` if an earlier call of this
 * C call threw, or if this one throws (the exception is kept for `CallScope::finish`).
 */
template <class R, class Body>
R guarded(R fallback, Body &&body) noexcept {
    if (pending()) return fallback;
    try {
        return body();
    } catch (...) {
        pending() = std::current_exception();
        return fallback;
    }
}

template <class Body>
void guarded_void(Body &&body) noexcept {
    if (pending()) return;
    try {
        body();
    } catch (...) {
        pending() = std::current_exception();
    }
}

/** The address of a callable as C's `void *user_data`. */
template <class G>
void *user_data(G &g) noexcept {
    return const_cast<void *>(static_cast<const void *>(std::addressof(g)));
}

template <class G>
int32_t occluded_trampoline(void *user, ml_vec3 x, ml_vec3 d, float t) noexcept {
    return guarded<int32_t>(1, [&] { return (*static_cast<G *>(user))(x, d, t) ? 1 : 0; });
}

template <class G>
float first_hit_trampoline(void *user, ml_vec3 x, ml_vec3 d) noexcept {
    return guarded<float>(0.0f, [&] { return static_cast<float>((*static_cast<G *>(user))(x, d)); });
}

template <class G>
int32_t vpl_visible_trampoline(void *user, ml_vec3 importon, ml_vec3 vpl) noexcept {
    return guarded<int32_t>(0,
                            [&] { return (*static_cast<G *>(user))(importon, vpl) ? 1 : 0; });
}

template <class G>
void hit_trampoline(void *user, const ml_light_hit *hit) noexcept {
    guarded_void([&] { (*static_cast<G *>(user))(*hit); });
}

/** The two callables of `ml_uniforms` (the second may be absent). */
template <class F32, class F64>
struct UniformPair {
    F32 f32;
    F64 f64;
};

template <class P>
float next_f32_trampoline(void *user) noexcept {
    return guarded<float>(0.0f, [&] { return static_cast<float>(static_cast<P *>(user)->f32()); });
}

template <class P>
double next_f64_trampoline(void *user) noexcept {
    return guarded<double>(0.0, [&] { return static_cast<double>(static_cast<P *>(user)->f64()); });
}

/** The environment's callables, kept alive by the tree and what was made from it. */
template <class S, class E>
struct EnvironmentHolder {
    S sample;
    E eval;
};

template <class H>
int32_t environment_sample_trampoline(void *user, float u0, float u1, ml_vec3 *direction,
                                      ml_rgb *radiance, float *pdf) noexcept {
    return guarded<int32_t>(0, [&] {
        return static_cast<H *>(user)->sample(u0, u1, *direction, *radiance, *pdf) ? 1 : 0;
    });
}

template <class H>
void environment_eval_trampoline(void *user, ml_vec3 direction, ml_rgb *radiance,
                                 float *pdf) noexcept {
    *radiance = ml_rgb{0.0f, 0.0f, 0.0f};
    *pdf = 0.0f;
    guarded_void([&] { static_cast<H *>(user)->eval(direction, *radiance, *pdf); });
    if (pending()) {
        *radiance = ml_rgb{0.0f, 0.0f, 0.0f};
        *pdf = 0.0f;
    }
}

}  // namespace detail

// ---- spans ---------------------------------------------------------------------------

/**
 * A view of `size()` contiguous `T`s (C++20's `std::span` in brief): it does not own them,
 * which must outlive it. `Span<const T>` for inputs, `Span<T>` for outputs.
 */
template <class T>
class Span {
  public:
    /** An empty span. */
    constexpr Span() noexcept = default;
    /** `count` elements from `data` (may be null when `count` is 0). */
    constexpr Span(T *data, std::size_t count) noexcept : data_(data), size_(count) {}
    /** A C array. */
    template <std::size_t N>
    constexpr Span(T (&array)[N]) noexcept : data_(array), size_(N) {}  // NOLINT: implicit
    /** A `std::array` (of `T`, or of non-const `T` for a `Span<const T>`). */
    template <class U, std::size_t N,
              class = std::enable_if_t<std::is_convertible<U (*)[], T (*)[]>::value>>
    constexpr Span(std::array<U, N> &array) noexcept  // NOLINT: implicit
        : data_(array.data()), size_(N) {}
    /** A `const std::array` (for a `Span<const T>`). */
    template <class U, std::size_t N,
              class = std::enable_if_t<std::is_convertible<const U (*)[], T (*)[]>::value>>
    constexpr Span(const std::array<U, N> &array) noexcept  // NOLINT: implicit
        : data_(array.data()), size_(N) {}
    /** A `std::vector` (of `T`, or of non-const `T` for a `Span<const T>`). */
    template <class U, class A,
              class = std::enable_if_t<std::is_convertible<U (*)[], T (*)[]>::value>>
    Span(std::vector<U, A> &vector) noexcept  // NOLINT: implicit
        : data_(vector.data()), size_(vector.size()) {}
    /** A `const std::vector` (for a `Span<const T>`). */
    template <class U, class A,
              class = std::enable_if_t<std::is_convertible<const U (*)[], T (*)[]>::value>>
    Span(const std::vector<U, A> &vector) noexcept  // NOLINT: implicit
        : data_(vector.data()), size_(vector.size()) {}
    /** A `Span<U>` whose elements convert (`Span<T>` to `Span<const T>`). */
    template <class U, class = std::enable_if_t<std::is_convertible<U (*)[], T (*)[]>::value>>
    constexpr Span(Span<U> other) noexcept  // NOLINT: implicit
        : data_(other.data()), size_(other.size()) {}

    /** The first element (null for an empty span made so). */
    [[nodiscard]] constexpr T *data() const noexcept { return data_; }
    /** The number of elements. */
    [[nodiscard]] constexpr std::size_t size() const noexcept { return size_; }
    /** True with no element. */
    [[nodiscard]] constexpr bool empty() const noexcept { return size_ == 0; }
    /** Element `i` (unchecked; `i < size()`). */
    constexpr T &operator[](std::size_t i) const noexcept { return data_[i]; }
    /** Iteration. */
    [[nodiscard]] constexpr T *begin() const noexcept { return data_; }
    /** Iteration. */
    [[nodiscard]] constexpr T *end() const noexcept { return data_ + size_; }

  private:
    T *data_ = nullptr;
    std::size_t size_ = 0;
};

// ---- callbacks -----------------------------------------------------------------------

/** No visibility callback: nothing is occluded (the C ABI's NULL `visibility`). */
struct Unoccluded {};

/**
 * Shadow rays: `bool occluded(ml_vec3 x, ml_vec3 d, float t)` is true if a surface lies on the
 * ray from `x` along the unit `d` before distance `t`. Made by `ml::shadow_rays`; holds a
 * reference to an lvalue callable, or the moved rvalue one.
 */
template <class F>
class ShadowRays {
  public:
    /** Wraps `f`. */
    explicit ShadowRays(F &&f) : f_(std::forward<F>(f)) {}
    /** The C struct, valid while this object lives. */
    [[nodiscard]] ml_visibility c() noexcept {
        return ml_visibility{&detail::occluded_trampoline<std::remove_reference_t<F>>, nullptr,
                             detail::user_data(f_)};
    }

  private:
    F f_;
};

/**
 * First-surface distances: `float first_hit(ml_vec3 x, ml_vec3 d)` is the distance to the
 * first surface along the ray (+infinity for none; not NaN). Made by `ml::first_hit`.
 */
template <class F>
class FirstHit {
  public:
    /** Wraps `f`. */
    explicit FirstHit(F &&f) : f_(std::forward<F>(f)) {}
    /** The C struct, valid while this object lives. */
    [[nodiscard]] ml_visibility c() noexcept {
        return ml_visibility{nullptr, &detail::first_hit_trampoline<std::remove_reference_t<F>>,
                             detail::user_data(f_)};
    }

  private:
    F f_;
};

/**
 * The host's uniform numbers: `next_f32()` returns the next number in [0, 1) as a `float`,
 * and the optional `next_f64()` one with 53 bits as a `double`. Made by `ml::uniforms`.
 */
template <class F32, class F64>
class Uniforms {
  public:
    /** Wraps the two callables (`F64` = `std::nullptr_t`: none). */
    Uniforms(F32 &&f32, F64 &&f64) : pair_{std::forward<F32>(f32), std::forward<F64>(f64)} {}
    /** The C struct, valid while this object lives. */
    [[nodiscard]] ml_uniforms c() noexcept {
        using P = detail::UniformPair<F32, F64>;
        ml_uniforms u{&detail::next_f32_trampoline<P>, nullptr, &pair_};
        if constexpr (!std::is_same<std::decay_t<F64>, std::nullptr_t>::value) {
            u.next_f64 = &detail::next_f64_trampoline<P>;
        }
        return u;
    }

  private:
    detail::UniformPair<F32, F64> pair_;
};

/** Nothing is occluded. */
[[nodiscard]] inline Unoccluded unoccluded() noexcept { return {}; }

/** Shadow rays through `occluded(x, d, t)` (see `ShadowRays`). */
template <class F>
[[nodiscard]] ShadowRays<F> shadow_rays(F &&occluded) {
    return ShadowRays<F>(std::forward<F>(occluded));
}

/** First-surface distances through `first_hit(x, d)` (see `FirstHit`). */
template <class F>
[[nodiscard]] FirstHit<F> first_hit(F &&first_hit) {
    return FirstHit<F>(std::forward<F>(first_hit));
}

/** Uniform numbers from `next_f32()` alone (see `Uniforms`). */
template <class F32>
[[nodiscard]] Uniforms<F32, std::nullptr_t> uniforms(F32 &&next_f32) {
    return Uniforms<F32, std::nullptr_t>(std::forward<F32>(next_f32), nullptr);
}

/** Uniform numbers from `next_f32()` and `next_f64()` (see `Uniforms`). */
template <class F32, class F64>
[[nodiscard]] Uniforms<F32, F64> uniforms(F32 &&next_f32, F64 &&next_f64) {
    return Uniforms<F32, F64>(std::forward<F32>(next_f32), std::forward<F64>(next_f64));
}

namespace detail {

inline const ml_visibility *c_visibility(Unoccluded, ml_visibility &) noexcept { return nullptr; }
inline const ml_visibility *c_visibility(const ml_visibility &v, ml_visibility &) noexcept {
    return &v;
}
template <class F>
const ml_visibility *c_visibility(ShadowRays<F> &v, ml_visibility &slot) noexcept {
    slot = v.c();
    return &slot;
}
template <class F>
const ml_visibility *c_visibility(FirstHit<F> &v, ml_visibility &slot) noexcept {
    slot = v.c();
    return &slot;
}
inline ml_uniforms c_uniforms(const ml_uniforms &u) noexcept { return u; }
template <class F32, class F64>
ml_uniforms c_uniforms(Uniforms<F32, F64> &u) noexcept {
    return u.c();
}

}  // namespace detail

/**
 * The host's environment (a sky or an environment map), given once to `Tree::build`,
 * `Tree::build_parallel` or `Tree::load_with_lights`. Made by `ml::environment`; copies
 * share the callables, which live until the last tree, estimator and cut made with it is
 * gone (an lvalue callable is referred to and must live that long itself). See
 * `ml_environment` for the contract of the values.
 */
class Environment {
  public:
    /** Wraps a C environment (its `user_data` must outlive the tree, as in C). */
    explicit Environment(const ml_environment &c) : c_(c) {}
    /** The C struct. */
    [[nodiscard]] const ml_environment &c() const noexcept { return c_; }
    /** What keeps the callables alive (empty for a wrapped C environment). */
    [[nodiscard]] const std::shared_ptr<void> &keep_alive() const noexcept { return keep_; }

  private:
    template <class S, class E>
    friend Environment environment(S &&, E &&, const std::array<float, 6> &);
    Environment(std::shared_ptr<void> keep, const ml_environment &c)
        : keep_(std::move(keep)), c_(c) {}
    std::shared_ptr<void> keep_;
    ml_environment c_;
};

/**
 * An environment of two callables and its irradiance bounds (+x, −x, +y, −y, +z, −z):
 * `bool sample(float u0, float u1, ml_vec3 &direction, ml_rgb &radiance, float &pdf)` writes
 * a direction, its radiance and solid-angle pdf (> 0) and returns true, or returns false for
 * no sample; `void eval(ml_vec3 direction, ml_rgb &radiance, float &pdf)` writes the radiance
 * along the unit `direction` and the pdf with which `sample` returns it. Both may be called
 * from several threads at once. An exception from them is rethrown by the call that made the
 * library call them (an estimate, a point on a light), as for every callable.
 */
template <class S, class E>
[[nodiscard]] Environment environment(S &&sample, E &&eval,
                                      const std::array<float, 6> &irradiance_bounds) {
    using H = detail::EnvironmentHolder<S, E>;
    auto holder = std::make_shared<H>(H{std::forward<S>(sample), std::forward<E>(eval)});
    ml_environment c{};
    c.sample = &detail::environment_sample_trampoline<H>;
    c.eval = &detail::environment_eval_trampoline<H>;
    c.user_data = holder.get();
    for (std::size_t i = 0; i < 6; i++) c.irradiance_bounds[i] = irradiance_bounds[i];
    return Environment(std::shared_ptr<void>(std::move(holder)), c);
}

// ---- values --------------------------------------------------------------------------

/** The version of the library actually loaded (the header's is `ML_VERSION_*`). */
struct Version {
    /** Major. */
    uint32_t major;
    /** Minor. */
    uint32_t minor;
    /** Patch. */
    uint32_t patch;
};

/** The version of the library actually loaded. */
[[nodiscard]] inline Version version() noexcept {
    Version v{0, 0, 0};
    (void)ml_version(&v.major, &v.minor, &v.patch);
    return v;
}

/** The default build options. */
[[nodiscard]] inline ml_build_options build_options() noexcept {
    ml_build_options o{};
    (void)ml_build_options_default(&o);
    return o;
}

/** The default options of the BRDF-oriented cut. */
[[nodiscard]] inline ml_bl_cut_options bl_cut_options() noexcept {
    ml_bl_cut_options o{};
    (void)ml_bl_cut_options_default(&o);
    return o;
}

/** The default options of the split-sampling cut. */
[[nodiscard]] inline ml_split_cut_options split_cut_options() noexcept {
    ml_split_cut_options o{};
    (void)ml_split_cut_options_default(&o);
    return o;
}

/** The estimators' default parameters. */
[[nodiscard]] inline ml_direct_params direct_params() noexcept {
    ml_direct_params p{};
    (void)ml_direct_params_default(&p);
    return p;
}

/** The default acceptor options with `pixels` and `wanted` set. */
[[nodiscard]] inline ml_acceptor_options acceptor_options(std::size_t pixels,
                                                          std::size_t wanted) noexcept {
    ml_acceptor_options o{};
    (void)ml_acceptor_options_default(&o);
    o.pixels = pixels;
    o.wanted = wanted;
    return o;
}

/** An isotropic point light of intensity I (W/sr). */
[[nodiscard]] inline ml_light point_light(ml_vec3 position, ml_rgb intensity) noexcept {
    ml_light l{};
    l.point.kind = ML_LIGHT_KIND_POINT;
    l.point.position = position;
    l.point.intensity = intensity;
    return l;
}

/** A spot light: intensity I on `axis`, half-angle θs, falloff start θf (radians). */
[[nodiscard]] inline ml_light spot_light(ml_vec3 position, ml_vec3 axis, ml_rgb intensity,
                                         float half_angle, float falloff_start) noexcept {
    ml_light l{};
    l.spot.kind = ML_LIGHT_KIND_SPOT;
    l.spot.position = position;
    l.spot.axis = axis;
    l.spot.intensity = intensity;
    l.spot.half_angle = half_angle;
    l.spot.falloff_start = falloff_start;
    return l;
}

/** A sphere light of radiance L (W/(m²·sr)). */
[[nodiscard]] inline ml_light sphere_light(ml_vec3 center, float radius, ml_rgb radiance) noexcept {
    ml_light l{};
    l.sphere.kind = ML_LIGHT_KIND_SPHERE;
    l.sphere.center = center;
    l.sphere.radius = radius;
    l.sphere.radiance = radiance;
    return l;
}

/** A disk light of radiance L, on the normal's side or both. */
[[nodiscard]] inline ml_light disk_light(ml_vec3 center, ml_vec3 normal, float radius,
                                         ml_rgb radiance, bool two_sided = false) noexcept {
    ml_light l{};
    l.disk.kind = ML_LIGHT_KIND_DISK;
    l.disk.center = center;
    l.disk.normal = normal;
    l.disk.radius = radius;
    l.disk.radiance = radiance;
    l.disk.two_sided = two_sided ? 1u : 0u;
    return l;
}

/** A triangle light of radiance L, on the side of (v1 − v0) × (v2 − v0) or both. */
[[nodiscard]] inline ml_light triangle_light(ml_vec3 v0, ml_vec3 v1, ml_vec3 v2, ml_rgb radiance,
                                             bool two_sided = false) noexcept {
    ml_light l{};
    l.triangle.kind = ML_LIGHT_KIND_TRIANGLE;
    l.triangle.v0 = v0;
    l.triangle.v1 = v1;
    l.triangle.v2 = v2;
    l.triangle.radiance = radiance;
    l.triangle.two_sided = two_sided ? 1u : 0u;
    return l;
}

/** A virtual point light of intensity I along its normal. */
[[nodiscard]] inline ml_light vpl_light(ml_vec3 position, ml_vec3 normal, ml_rgb intensity) noexcept {
    ml_light l{};
    l.vpl.kind = ML_LIGHT_KIND_VPL;
    l.vpl.position = position;
    l.vpl.normal = normal;
    l.vpl.intensity = intensity;
    return l;
}

/** A distant light towards `direction`, angular radius γ (0: a delta), irradiance E. */
[[nodiscard]] inline ml_light distant_light(ml_vec3 direction, float angular_radius,
                                            ml_rgb irradiance) noexcept {
    ml_light l{};
    l.distant.kind = ML_LIGHT_KIND_DISTANT;
    l.distant.direction = direction;
    l.distant.angular_radius = angular_radius;
    l.distant.irradiance = irradiance;
    return l;
}

/** A Lambert material: f = albedo/π. */
[[nodiscard]] inline ml_material lambert(ml_rgb albedo) noexcept {
    return ml_material{ML_MATERIAL_KIND_LAMBERT, albedo, 0.0f, 1.0f};
}

/** A GGX material: f = specular · GGX(α). */
[[nodiscard]] inline ml_material ggx(float specular, float alpha) noexcept {
    return ml_material{ML_MATERIAL_KIND_GGX, ml_rgb{0.0f, 0.0f, 0.0f}, specular, alpha};
}

/** A plastic material: f = albedo/π + specular · GGX(α). */
[[nodiscard]] inline ml_material plastic(ml_rgb albedo, float specular, float alpha) noexcept {
    return ml_material{ML_MATERIAL_KIND_PLASTIC, albedo, specular, alpha};
}

// ---- BRDFs ---------------------------------------------------------------------------

/** `ml_brdf_sample`: a direction from `sp`'s material with `u0`, `u1` in [0, 1). */
[[nodiscard]] inline Result<ml_brdf_draw> try_brdf_sample(const ml_shading_point &sp, float u0,
                                                          float u1) {
    ml_brdf_draw d{};
    const ml_status s = ml_brdf_sample(&sp, u0, u1, &d);
    return detail::result(s, d);
}
/** `ml_brdf_sample`, throwing. */
[[nodiscard]] inline ml_brdf_draw brdf_sample(const ml_shading_point &sp, float u0, float u1) {
    return try_brdf_sample(sp, u0, u1).value();
}

/** `ml_brdf_pdf`: the solid-angle pdf of `wi`. */
[[nodiscard]] inline Result<float> try_brdf_pdf(const ml_shading_point &sp, ml_vec3 wi) {
    float p = 0.0f;
    const ml_status s = ml_brdf_pdf(&sp, wi, &p);
    return detail::result(s, p);
}
/** `ml_brdf_pdf`, throwing. */
[[nodiscard]] inline float brdf_pdf(const ml_shading_point &sp, ml_vec3 wi) {
    return try_brdf_pdf(sp, wi).value();
}

/** `ml_brdf_eval`: f(ωo, ωi) per channel. */
[[nodiscard]] inline Result<ml_rgb> try_brdf_eval(const ml_shading_point &sp, ml_vec3 wi) {
    ml_rgb f{};
    const ml_status s = ml_brdf_eval(&sp, wi, &f);
    return detail::result(s, f);
}
/** `ml_brdf_eval`, throwing. */
[[nodiscard]] inline ml_rgb brdf_eval(const ml_shading_point &sp, ml_vec3 wi) {
    return try_brdf_eval(sp, wi).value();
}

// ---- the tree ------------------------------------------------------------------------

/**
 * A light tree (`ml_tree`), with the lights it was built from and its environment: immutable,
 * its `const` methods callable from any number of threads at once. Estimators and cuts made
 * from it keep it (and its environment's callables) alive: it may be destroyed first.
 */
class Tree {
  public:
    /** An empty tree handle. */
    Tree() noexcept = default;
    /** Takes ownership of a C tree (freed by the destructor). */
    explicit Tree(ml_tree *owned) noexcept : tree_(owned) {}
    Tree(const Tree &) = delete;
    Tree &operator=(const Tree &) = delete;
    /** Moves the handle; `other` is left empty. */
    Tree(Tree &&other) noexcept
        : tree_(std::exchange(other.tree_, nullptr)), keep_(std::move(other.keep_)) {}
    /** Frees this tree, then takes `other`'s handle; `other` is left empty. */
    Tree &operator=(Tree &&other) noexcept {
        if (this != &other) {
            reset();
            tree_ = std::exchange(other.tree_, nullptr);
            keep_ = std::move(other.keep_);
        }
        return *this;
    }
    ~Tree() { reset(); }

    /** The C handle (owned by this object; null when empty). */
    [[nodiscard]] ml_tree *get() const noexcept { return tree_; }
    /** True unless empty. */
    explicit operator bool() const noexcept { return tree_ != nullptr; }
    /** What keeps the environment's callables alive (for handles made from the tree). */
    [[nodiscard]] const std::shared_ptr<void> &keep_alive() const noexcept { return keep_; }

    /** `ml_tree_build`: a tree of `lights` (the environment: none). */
    [[nodiscard]] static Result<Tree> try_build(Span<const ml_light> lights,
                                                const ml_build_options *options = nullptr) {
        ml_tree *t = nullptr;
        ml_status s = ml_tree_build(lights.data(), lights.size(), nullptr, options, &t);
        return detail::result(s, Tree(t));
    }
    /** `ml_tree_build`, throwing. */
    [[nodiscard]] static Tree build(Span<const ml_light> lights,
                                    const ml_build_options *options = nullptr) {
        return try_build(lights, options).value();
    }
    /** `ml_tree_build` with an environment (light `lights.size()`). */
    [[nodiscard]] static Result<Tree> try_build(Span<const ml_light> lights,
                                                const Environment &environment,
                                                const ml_build_options *options = nullptr) {
        ml_tree *t = nullptr;
        ml_status s =
            ml_tree_build(lights.data(), lights.size(), &environment.c(), options, &t);
        return detail::result(s, Tree(t, environment.keep_alive()));
    }
    /** `ml_tree_build` with an environment, throwing. */
    [[nodiscard]] static Tree build(Span<const ml_light> lights, const Environment &environment,
                                    const ml_build_options *options = nullptr) {
        return try_build(lights, environment, options).value();
    }
    /** `ml_tree_build_parallel` on `threads` threads (0: one per core), the same tree. */
    [[nodiscard]] static Result<Tree> try_build_parallel(Span<const ml_light> lights,
                                                         uint32_t threads,
                                                         const ml_build_options *options = nullptr) {
        ml_tree *t = nullptr;
        ml_status s =
            ml_tree_build_parallel(lights.data(), lights.size(), nullptr, options, threads, &t);
        return detail::result(s, Tree(t));
    }
    /** `ml_tree_build_parallel`, throwing. */
    [[nodiscard]] static Tree build_parallel(Span<const ml_light> lights, uint32_t threads,
                                             const ml_build_options *options = nullptr) {
        return try_build_parallel(lights, threads, options).value();
    }
    /** `ml_tree_build_parallel` with an environment. */
    [[nodiscard]] static Result<Tree> try_build_parallel(Span<const ml_light> lights,
                                                         const Environment &environment,
                                                         uint32_t threads,
                                                         const ml_build_options *options = nullptr) {
        ml_tree *t = nullptr;
        ml_status s = ml_tree_build_parallel(lights.data(), lights.size(), &environment.c(),
                                             options, threads, &t);
        return detail::result(s, Tree(t, environment.keep_alive()));
    }
    /** `ml_tree_build_parallel` with an environment, throwing. */
    [[nodiscard]] static Tree build_parallel(Span<const ml_light> lights,
                                             const Environment &environment, uint32_t threads,
                                             const ml_build_options *options = nullptr) {
        return try_build_parallel(lights, environment, threads, options).value();
    }
    /** `ml_tree_load`: a tree from `serialize`'s bytes, without its lights. */
    [[nodiscard]] static Result<Tree> try_load(Span<const uint8_t> bytes) {
        ml_tree *t = nullptr;
        const ml_status s = ml_tree_load(bytes.data(), bytes.size(), &t);
        return detail::result(s, Tree(t));
    }
    /** `ml_tree_load`, throwing. */
    [[nodiscard]] static Tree load(Span<const uint8_t> bytes) { return try_load(bytes).value(); }
    /** `ml_tree_load_with_lights` (the tree had no environment). */
    [[nodiscard]] static Result<Tree> try_load_with_lights(Span<const uint8_t> bytes,
                                                           Span<const ml_light> lights) {
        ml_tree *t = nullptr;
        ml_status s = ml_tree_load_with_lights(bytes.data(), bytes.size(), lights.data(),
                                               lights.size(), nullptr, &t);
        return detail::result(s, Tree(t));
    }
    /** `ml_tree_load_with_lights`, throwing. */
    [[nodiscard]] static Tree load_with_lights(Span<const uint8_t> bytes,
                                               Span<const ml_light> lights) {
        return try_load_with_lights(bytes, lights).value();
    }
    /** `ml_tree_load_with_lights` with the tree's environment. */
    [[nodiscard]] static Result<Tree> try_load_with_lights(Span<const uint8_t> bytes,
                                                           Span<const ml_light> lights,
                                                           const Environment &environment) {
        ml_tree *t = nullptr;
        ml_status s = ml_tree_load_with_lights(bytes.data(), bytes.size(), lights.data(),
                                               lights.size(), &environment.c(), &t);
        return detail::result(s, Tree(t, environment.keep_alive()));
    }
    /** `ml_tree_load_with_lights` with the tree's environment, throwing. */
    [[nodiscard]] static Tree load_with_lights(Span<const uint8_t> bytes,
                                               Span<const ml_light> lights,
                                               const Environment &environment) {
        return try_load_with_lights(bytes, lights, environment).value();
    }

    /** `ml_tree_stats`. */
    [[nodiscard]] Result<ml_tree_statistics> try_stats() const {
        ml_tree_statistics st{};
        const ml_status s = ml_tree_stats(tree_, &st);
        return detail::result(s, st);
    }
    /** `ml_tree_stats`, throwing. */
    [[nodiscard]] ml_tree_statistics stats() const { return try_stats().value(); }

    /** `ml_tree_serialized_size`. */
    [[nodiscard]] Result<std::size_t> try_serialized_size() const {
        std::size_t n = 0;
        const ml_status s = ml_tree_serialized_size(tree_, &n);
        return detail::result(s, n);
    }
    /** `ml_tree_serialized_size`, throwing. */
    [[nodiscard]] std::size_t serialized_size() const { return try_serialized_size().value(); }

    /** `ml_tree_serialize` into `buffer`: the number of bytes written. */
    [[nodiscard]] Result<std::size_t> try_serialize(Span<uint8_t> buffer) const {
        std::size_t n = 0;
        const ml_status s = ml_tree_serialize(tree_, buffer.data(), buffer.size(), &n);
        return detail::result(s, n);
    }
    /** `ml_tree_serialize` into `buffer`, throwing. */
    std::size_t serialize(Span<uint8_t> buffer) const { return try_serialize(buffer).value(); }
    /** `ml_tree_serialize` into a new vector. */
    [[nodiscard]] Result<std::vector<uint8_t>> try_serialize() const {
        Result<std::size_t> size = try_serialized_size();
        if (!size) return Result<std::vector<uint8_t>>(size.status(), size.message());
        std::vector<uint8_t> bytes(size.value());
        Result<std::size_t> n = try_serialize(Span<uint8_t>(bytes));
        if (!n) return Result<std::vector<uint8_t>>(n.status(), n.message());
        bytes.resize(n.value());
        return bytes;
    }
    /** `ml_tree_serialize` into a new vector, throwing. */
    [[nodiscard]] std::vector<uint8_t> serialize() const { return try_serialize().value(); }

    /** `ml_tree_sample_tl`: a light by TL importance at `point` with `u` in [0, 1). */
    [[nodiscard]] Result<ml_sampled_light> try_sample_tl(const ml_tl_point &point,
                                                         float u) const {
        ml_sampled_light out = ML_SAMPLED_LIGHT_NONE;
        const ml_status s = ml_tree_sample_tl(tree_, &point, u, &out);
        return detail::result(s, out);
    }
    /** `ml_tree_sample_tl`, throwing. */
    [[nodiscard]] ml_sampled_light sample_tl(const ml_tl_point &point, float u) const {
        return try_sample_tl(point, u).value();
    }
    /** `ml_tree_pmf_tl`: the probability that `sample_tl` returns `light`. */
    [[nodiscard]] Result<float> try_pmf_tl(const ml_tl_point &point, uint32_t light) const {
        float p = 0.0f;
        const ml_status s = ml_tree_pmf_tl(tree_, &point, light, &p);
        return detail::result(s, p);
    }
    /** `ml_tree_pmf_tl`, throwing. */
    [[nodiscard]] float pmf_tl(const ml_tl_point &point, uint32_t light) const {
        return try_pmf_tl(point, light).value();
    }
    /** `ml_tree_sample_bl`: a light by BRDF-oriented importance at `sp`. */
    [[nodiscard]] Result<ml_sampled_light> try_sample_bl(const ml_shading_point &sp,
                                                         float u) const {
        ml_sampled_light out = ML_SAMPLED_LIGHT_NONE;
        const ml_status s = ml_tree_sample_bl(tree_, &sp, u, &out);
        return detail::result(s, out);
    }
    /** `ml_tree_sample_bl`, throwing. */
    [[nodiscard]] ml_sampled_light sample_bl(const ml_shading_point &sp, float u) const {
        return try_sample_bl(sp, u).value();
    }
    /** `ml_tree_pmf_bl`: the probability that `sample_bl` returns `light`. */
    [[nodiscard]] Result<float> try_pmf_bl(const ml_shading_point &sp, uint32_t light) const {
        float p = 0.0f;
        const ml_status s = ml_tree_pmf_bl(tree_, &sp, light, &p);
        return detail::result(s, p);
    }
    /** `ml_tree_pmf_bl`, throwing. */
    [[nodiscard]] float pmf_bl(const ml_shading_point &sp, uint32_t light) const {
        return try_pmf_bl(sp, light).value();
    }

    /** `ml_tree_sample_tl_batch`: `out[j]` for `points[j]`, `us[j]` (equal lengths). */
    Result<void> try_sample_tl_batch(Span<const ml_tl_point> points, Span<const float> us,
                                     Span<ml_sampled_light> out) const {
        const char *fn = "ml::Tree::sample_tl_batch";
        if (us.size() != points.size())
            return detail::invalid<void>(fn, "us", us.size(), "points", points.size());
        if (out.size() != points.size())
            return detail::invalid<void>(fn, "out", out.size(), "points", points.size());
        return detail::result(
            ml_tree_sample_tl_batch(tree_, points.data(), us.data(), points.size(), out.data()));
    }
    /** `ml_tree_sample_tl_batch`, throwing. */
    void sample_tl_batch(Span<const ml_tl_point> points, Span<const float> us,
                         Span<ml_sampled_light> out) const {
        try_sample_tl_batch(points, us, out).value();
    }
    /** `ml_tree_pmf_tl_batch`: `out[j]` = pmf of `lights[j]` at `points[j]`. */
    Result<void> try_pmf_tl_batch(Span<const ml_tl_point> points, Span<const uint32_t> lights,
                                  Span<float> out) const {
        const char *fn = "ml::Tree::pmf_tl_batch";
        if (lights.size() != points.size())
            return detail::invalid<void>(fn, "lights", lights.size(), "points", points.size());
        if (out.size() != points.size())
            return detail::invalid<void>(fn, "out", out.size(), "points", points.size());
        return detail::result(ml_tree_pmf_tl_batch(tree_, points.data(), lights.data(),
                                                   points.size(), out.data()));
    }
    /** `ml_tree_pmf_tl_batch`, throwing. */
    void pmf_tl_batch(Span<const ml_tl_point> points, Span<const uint32_t> lights,
                      Span<float> out) const {
        try_pmf_tl_batch(points, lights, out).value();
    }
    /** `ml_tree_sample_bl_batch`: `out[j]` for `points[j]`, `us[j]`. */
    Result<void> try_sample_bl_batch(Span<const ml_shading_point> points, Span<const float> us,
                                     Span<ml_sampled_light> out) const {
        const char *fn = "ml::Tree::sample_bl_batch";
        if (us.size() != points.size())
            return detail::invalid<void>(fn, "us", us.size(), "points", points.size());
        if (out.size() != points.size())
            return detail::invalid<void>(fn, "out", out.size(), "points", points.size());
        return detail::result(
            ml_tree_sample_bl_batch(tree_, points.data(), us.data(), points.size(), out.data()));
    }
    /** `ml_tree_sample_bl_batch`, throwing. */
    void sample_bl_batch(Span<const ml_shading_point> points, Span<const float> us,
                         Span<ml_sampled_light> out) const {
        try_sample_bl_batch(points, us, out).value();
    }
    /** `ml_tree_pmf_bl_batch`: `out[j]` = pmf of `lights[j]` at `points[j]`. */
    Result<void> try_pmf_bl_batch(Span<const ml_shading_point> points,
                                  Span<const uint32_t> lights, Span<float> out) const {
        const char *fn = "ml::Tree::pmf_bl_batch";
        if (lights.size() != points.size())
            return detail::invalid<void>(fn, "lights", lights.size(), "points", points.size());
        if (out.size() != points.size())
            return detail::invalid<void>(fn, "out", out.size(), "points", points.size());
        return detail::result(ml_tree_pmf_bl_batch(tree_, points.data(), lights.data(),
                                                   points.size(), out.data()));
    }
    /** `ml_tree_pmf_bl_batch`, throwing. */
    void pmf_bl_batch(Span<const ml_shading_point> points, Span<const uint32_t> lights,
                      Span<float> out) const {
        try_pmf_bl_batch(points, lights, out).value();
    }

    /** `ml_light_sample_point`: a point on `light` seen from `x` (may call the environment). */
    [[nodiscard]] Result<ml_light_point> try_light_sample_point(uint32_t light, ml_vec3 x,
                                                                float u0, float u1) const {
        ml_light_point p{};
        detail::CallScope scope;
        ml_status s = ml_light_sample_point(tree_, light, x, u0, u1, &p);
        scope.finish();
        return detail::result(s, p);
    }
    /** `ml_light_sample_point`, throwing. */
    [[nodiscard]] ml_light_point light_sample_point(uint32_t light, ml_vec3 x, float u0,
                                                    float u1) const {
        return try_light_sample_point(light, x, u0, u1).value();
    }
    /** `ml_light_pdf_point`: the solid-angle pdf of `point` on `light` from `x`. */
    [[nodiscard]] Result<float> try_light_pdf_point(uint32_t light, ml_vec3 x,
                                                    ml_vec3 point) const {
        float p = 0.0f;
        detail::CallScope scope;
        ml_status s = ml_light_pdf_point(tree_, light, x, point, &p);
        scope.finish();
        return detail::result(s, p);
    }
    /** `ml_light_pdf_point`, throwing. */
    [[nodiscard]] float light_pdf_point(uint32_t light, ml_vec3 x, ml_vec3 point) const {
        return try_light_pdf_point(light, x, point).value();
    }
    /** `ml_light_sample_point_batch`: `out[j]` on `lights[j]` from `xs[j]` (equal lengths). */
    Result<void> try_light_sample_point_batch(Span<const uint32_t> lights,
                                              Span<const ml_vec3> xs, Span<const float> u0s,
                                              Span<const float> u1s,
                                              Span<ml_light_point> out) const {
        const char *fn = "ml::Tree::light_sample_point_batch";
        const std::size_t n = lights.size();
        if (xs.size() != n) return detail::invalid<void>(fn, "xs", xs.size(), "lights", n);
        if (u0s.size() != n) return detail::invalid<void>(fn, "u0s", u0s.size(), "lights", n);
        if (u1s.size() != n) return detail::invalid<void>(fn, "u1s", u1s.size(), "lights", n);
        if (out.size() != n) return detail::invalid<void>(fn, "out", out.size(), "lights", n);
        detail::CallScope scope;
        ml_status s = ml_light_sample_point_batch(tree_, lights.data(), xs.data(), u0s.data(),
                                                  u1s.data(), n, out.data());
        scope.finish();
        return detail::result(s);
    }
    /** `ml_light_sample_point_batch`, throwing. */
    void light_sample_point_batch(Span<const uint32_t> lights, Span<const ml_vec3> xs,
                                  Span<const float> u0s, Span<const float> u1s,
                                  Span<ml_light_point> out) const {
        try_light_sample_point_batch(lights, xs, u0s, u1s, out).value();
    }

    /**
     * `ml_direct_estimate`: one estimate at `sp` with `technique` (an `ml_technique`),
     * `params` (null: defaults), `visibility` (`ml::unoccluded()`, `ml::shadow_rays(f)`,
     * `ml::first_hit(f)` or an `ml_visibility`) and `uniforms` (`ml::uniforms(...)` or an
     * `ml_uniforms`).
     */
    template <class V, class U>
    [[nodiscard]] Result<ml_rgb64> try_direct_estimate(const ml_shading_point &sp,
                                                       uint32_t technique,
                                                       const ml_direct_params *params,
                                                       V &&visibility, U &&uniforms) const {
        ml_visibility slot{};
        const ml_visibility *vis = detail::c_visibility(visibility, slot);
        ml_uniforms u = detail::c_uniforms(uniforms);
        ml_rgb64 e{0.0, 0.0, 0.0};
        detail::CallScope scope;
        ml_status s = ml_direct_estimate(tree_, &sp, technique, params, vis, &u, &e);
        scope.finish();
        return detail::result(s, e);
    }
    /** `ml_direct_estimate`, throwing. */
    template <class V, class U>
    [[nodiscard]] ml_rgb64 direct_estimate(const ml_shading_point &sp, uint32_t technique,
                                           const ml_direct_params *params, V &&visibility,
                                           U &&uniforms) const {
        return try_direct_estimate(sp, technique, params, std::forward<V>(visibility),
                                   std::forward<U>(uniforms))
            .value();
    }
    /**
     * `ml_direct_estimate_batch`: `per_point` estimates at each of `points`, into `out`
     * (`points.size() * per_point` of them, `out[j * per_point + i]`).
     */
    template <class V, class U>
    Result<void> try_direct_estimate_batch(Span<const ml_shading_point> points,
                                           uint32_t per_point, uint32_t technique,
                                           const ml_direct_params *params, V &&visibility,
                                           U &&uniforms, Span<ml_rgb64> out) const {
        const std::size_t want = points.size() * per_point;
        if (per_point != 0 && out.size() != want) {
            return detail::invalid<void>("ml::Tree::direct_estimate_batch", "out", out.size(),
                                         "points times per_point", want);
        }
        ml_visibility slot{};
        const ml_visibility *vis = detail::c_visibility(visibility, slot);
        ml_uniforms u = detail::c_uniforms(uniforms);
        detail::CallScope scope;
        ml_status s = ml_direct_estimate_batch(tree_, points.data(), points.size(), per_point,
                                               technique, params, vis, &u, out.data());
        scope.finish();
        return detail::result(s);
    }
    /** `ml_direct_estimate_batch`, throwing. */
    template <class V, class U>
    void direct_estimate_batch(Span<const ml_shading_point> points, uint32_t per_point,
                               uint32_t technique, const ml_direct_params *params,
                               V &&visibility, U &&uniforms, Span<ml_rgb64> out) const {
        try_direct_estimate_batch(points, per_point, technique, params,
                                  std::forward<V>(visibility), std::forward<U>(uniforms), out)
            .value();
    }

  private:
    Tree(ml_tree *owned, std::shared_ptr<void> keep) noexcept
        : tree_(owned), keep_(owned != nullptr ? std::move(keep) : nullptr) {}
    void reset() noexcept {
        if (tree_ != nullptr) (void)ml_tree_free(tree_);
        tree_ = nullptr;
        keep_.reset();
    }
    ml_tree *tree_ = nullptr;
    std::shared_ptr<void> keep_;
};

// ---- cuts ----------------------------------------------------------------------------

/** `ml_cut_pmf_in`'s answer: the cluster holding a light and its pmf within it. */
struct ClusterPmf {
    /** The cluster's index, or `ML_NO_CLUSTER`. */
    uint32_t cluster;
    /** The light's pmf within it (0 with `ML_NO_CLUSTER`). */
    float pmf;
};

/**
 * A light cut (`ml_cut`): per-thread state, rebuilt for each shading point; it keeps the tree
 * it was last built on alive. One thread at a time.
 */
class Cut {
  public:
    /** An empty cut handle (`create` makes a cut). */
    Cut() noexcept = default;
    /** Takes ownership of a C cut. */
    explicit Cut(ml_cut *owned) noexcept : cut_(owned) {}
    Cut(const Cut &) = delete;
    Cut &operator=(const Cut &) = delete;
    /** Moves the handle; `other` is left empty. */
    Cut(Cut &&other) noexcept
        : cut_(std::exchange(other.cut_, nullptr)), keep_(std::move(other.keep_)) {}
    /** Frees this cut, then takes `other`'s handle; `other` is left empty. */
    Cut &operator=(Cut &&other) noexcept {
        if (this != &other) {
            reset();
            cut_ = std::exchange(other.cut_, nullptr);
            keep_ = std::move(other.keep_);
        }
        return *this;
    }
    ~Cut() { reset(); }

    /** The C handle (owned by this object; null when empty). */
    [[nodiscard]] ml_cut *get() const noexcept { return cut_; }
    /** True unless empty. */
    explicit operator bool() const noexcept { return cut_ != nullptr; }

    /** `ml_cut_create`: an empty cut, never built. */
    [[nodiscard]] static Result<Cut> try_create() {
        ml_cut *c = nullptr;
        const ml_status s = ml_cut_create(&c);
        return detail::result(s, Cut(c));
    }
    /** `ml_cut_create`, throwing. */
    [[nodiscard]] static Cut create() { return try_create().value(); }

    /** `ml_cut_build_bl`: the BRDF-oriented cut of `tree` at `sp` (`options` null: defaults). */
    Result<void> try_build_bl(const Tree &tree, const ml_shading_point &sp,
                              const ml_bl_cut_options *options = nullptr) {
        ml_status s = ml_cut_build_bl(cut_, tree.get(), &sp, options);
        if (s == ML_OK) keep_ = tree.keep_alive();
        return detail::result(s);
    }
    /** `ml_cut_build_bl`, throwing. */
    void build_bl(const Tree &tree, const ml_shading_point &sp,
                  const ml_bl_cut_options *options = nullptr) {
        try_build_bl(tree, sp, options).value();
    }
    /** `ml_cut_build_split`: the split-sampling cut of `tree` at `point`. */
    Result<void> try_build_split(const Tree &tree, const ml_tl_point &point,
                                 const ml_split_cut_options *options = nullptr) {
        ml_status s = ml_cut_build_split(cut_, tree.get(), &point, options);
        if (s == ML_OK) keep_ = tree.keep_alive();
        return detail::result(s);
    }
    /** `ml_cut_build_split`, throwing. */
    void build_split(const Tree &tree, const ml_tl_point &point,
                     const ml_split_cut_options *options = nullptr) {
        try_build_split(tree, point, options).value();
    }

    /** `ml_cut_size`: its clusters. */
    [[nodiscard]] Result<std::size_t> try_size() const {
        std::size_t n = 0;
        const ml_status s = ml_cut_size(cut_, &n);
        return detail::result(s, n);
    }
    /** `ml_cut_size`, throwing. */
    [[nodiscard]] std::size_t size() const { return try_size().value(); }
    /** `ml_cut_ib`: IB(x) of a BRDF-oriented cut. */
    [[nodiscard]] Result<float> try_ib() const {
        float v = 0.0f;
        const ml_status s = ml_cut_ib(cut_, &v);
        return detail::result(s, v);
    }
    /** `ml_cut_ib`, throwing. */
    [[nodiscard]] float ib() const { return try_ib().value(); }
    /** `ml_cut_max_variance`: the largest normalised variance of a split cut. */
    [[nodiscard]] Result<float> try_max_variance() const {
        float v = 0.0f;
        const ml_status s = ml_cut_max_variance(cut_, &v);
        return detail::result(s, v);
    }
    /** `ml_cut_max_variance`, throwing. */
    [[nodiscard]] float max_variance() const { return try_max_variance().value(); }
    /** `ml_cut_sample`: one light of the whole cut with `u` in [0, 1). */
    [[nodiscard]] Result<ml_sampled_light> try_sample(float u) const {
        ml_sampled_light out = ML_SAMPLED_LIGHT_NONE;
        const ml_status s = ml_cut_sample(cut_, u, &out);
        return detail::result(s, out);
    }
    /** `ml_cut_sample`, throwing. */
    [[nodiscard]] ml_sampled_light sample(float u) const { return try_sample(u).value(); }
    /** `ml_cut_pmf`: the probability that `sample` returns `light`. */
    [[nodiscard]] Result<float> try_pmf(uint32_t light) const {
        float p = 0.0f;
        const ml_status s = ml_cut_pmf(cut_, light, &p);
        return detail::result(s, p);
    }
    /** `ml_cut_pmf`, throwing. */
    [[nodiscard]] float pmf(uint32_t light) const { return try_pmf(light).value(); }
    /** `ml_cut_sample_clusters`: one light per cluster, `out[i]` with `us[i]` (both `size()`). */
    Result<void> try_sample_clusters(Span<const float> us, Span<ml_sampled_light> out) const {
        if (out.size() != us.size()) {
            return detail::invalid<void>("ml::Cut::sample_clusters", "out", out.size(), "us",
                                         us.size());
        }
        return detail::result(ml_cut_sample_clusters(cut_, us.data(), us.size(), out.data()));
    }
    /** `ml_cut_sample_clusters`, throwing. */
    void sample_clusters(Span<const float> us, Span<ml_sampled_light> out) const {
        try_sample_clusters(us, out).value();
    }
    /** `ml_cut_pmf_in`: the cluster holding `light` and its pmf within it. */
    [[nodiscard]] Result<ClusterPmf> try_pmf_in(uint32_t light) const {
        ClusterPmf c{ML_NO_CLUSTER, 0.0f};
        const ml_status s = ml_cut_pmf_in(cut_, light, &c.cluster, &c.pmf);
        return detail::result(s, c);
    }
    /** `ml_cut_pmf_in`, throwing. */
    [[nodiscard]] ClusterPmf pmf_in(uint32_t light) const { return try_pmf_in(light).value(); }

  private:
    void reset() noexcept {
        if (cut_ != nullptr) (void)ml_cut_free(cut_);
        cut_ = nullptr;
        keep_.reset();
    }
    ml_cut *cut_ = nullptr;
    std::shared_ptr<void> keep_;
};

// ---- estimators ----------------------------------------------------------------------

// ---- learned visibility --------------------------------------------------------------

/**
 * A learned visibility cache (`ml_visibility_cache`) made for one tree: shared by every
 * thread's estimators (`Estimator::set_visibility_cache`), which record into it; `commit`
 * between passes (when no estimate runs) for the same bits on any number of threads. It keeps
 * its tree alive; an estimator keeps it alive.
 */
class VisibilityCache {
  public:
    /** An empty handle (`create` makes a cache). */
    VisibilityCache() noexcept = default;
    /** Takes ownership of a C cache. */
    explicit VisibilityCache(ml_visibility_cache *owned) noexcept : cache_(owned) {}
    VisibilityCache(const VisibilityCache &) = delete;
    VisibilityCache &operator=(const VisibilityCache &) = delete;
    /** Moves the handle; `other` is left empty. */
    VisibilityCache(VisibilityCache &&other) noexcept
        : cache_(std::exchange(other.cache_, nullptr)) {}
    /** Frees this cache, then takes `other`'s handle; `other` is left empty. */
    VisibilityCache &operator=(VisibilityCache &&other) noexcept {
        if (this != &other) {
            reset();
            cache_ = std::exchange(other.cache_, nullptr);
        }
        return *this;
    }
    ~VisibilityCache() { reset(); }

    /** The C handle (owned by this object; null when empty). */
    [[nodiscard]] ml_visibility_cache *get() const noexcept { return cache_; }
    /** True unless empty. */
    explicit operator bool() const noexcept { return cache_ != nullptr; }

    /** `ml_visibility_cache_options_default`: the default options for a cell size. */
    [[nodiscard]] static Result<ml_visibility_cache_options> try_options(float cell_size) {
        ml_visibility_cache_options o{};
        const ml_status s = ml_visibility_cache_options_default(cell_size, &o);
        return detail::result(s, o);
    }
    /** `ml_visibility_cache_options_default`, throwing. */
    [[nodiscard]] static ml_visibility_cache_options options(float cell_size) {
        return try_options(cell_size).value();
    }
    /** `ml_visibility_cache_create`: a cache for `tree` with nothing learned. */
    [[nodiscard]] static Result<VisibilityCache>
    try_create(const Tree &tree, const ml_visibility_cache_options &options) {
        ml_visibility_cache *c = nullptr;
        const ml_status s = ml_visibility_cache_create(tree.get(), &options, &c);
        return detail::result(s, VisibilityCache(c));
    }
    /** `ml_visibility_cache_create`, throwing. */
    [[nodiscard]] static VisibilityCache create(const Tree &tree,
                                                const ml_visibility_cache_options &options) {
        return try_create(tree, options).value();
    }
    /** `ml_visibility_cache_commit`: what was recorded becomes what sampling reads. */
    Result<void> try_commit() { return detail::result(ml_visibility_cache_commit(cache_)); }
    /** `ml_visibility_cache_commit`, throwing. */
    void commit() { try_commit().value(); }
    /** `ml_visibility_cache_clear`: forgets everything learned and pending. */
    Result<void> try_clear() { return detail::result(ml_visibility_cache_clear(cache_)); }
    /** `ml_visibility_cache_clear`, throwing. */
    void clear() { try_clear().value(); }
    /** `ml_visibility_cache_set_recording`: recording on or off. */
    Result<void> try_set_recording(bool on) {
        return detail::result(ml_visibility_cache_set_recording(cache_, on ? 1u : 0u));
    }
    /** `ml_visibility_cache_set_recording`, throwing. */
    void set_recording(bool on) { try_set_recording(on).value(); }
    /** `ml_visibility_cache_stats`: the counters with data, samples and visible samples. */
    [[nodiscard]] Result<ml_visibility_cache_counts> try_stats() const {
        ml_visibility_cache_counts c{};
        const ml_status s = ml_visibility_cache_stats(cache_, &c);
        return detail::result(s, c);
    }
    /** `ml_visibility_cache_stats`, throwing. */
    [[nodiscard]] ml_visibility_cache_counts stats() const { return try_stats().value(); }
    /** `ml_visibility_cache_bytes`: the bytes of its tables. */
    [[nodiscard]] Result<size_t> try_bytes() const {
        size_t n = 0;
        const ml_status s = ml_visibility_cache_bytes(cache_, &n);
        return detail::result(s, n);
    }
    /** `ml_visibility_cache_bytes`, throwing. */
    [[nodiscard]] size_t bytes() const { return try_bytes().value(); }

  private:
    void reset() noexcept {
        if (cache_ != nullptr) (void)ml_visibility_cache_free(cache_);
        cache_ = nullptr;
    }
    ml_visibility_cache *cache_ = nullptr;
};

/**
 * A per-point estimator (`ml_estimator`): per-thread state, set up at each shading point by
 * `set_point`, then any number of estimates (one call, or the lower level's steps). It keeps
 * its tree (and the tree's environment) alive. One thread at a time.
 */
class Estimator {
  public:
    /** An empty estimator handle (`create` makes one). */
    Estimator() noexcept = default;
    /** Takes ownership of a C estimator. */
    explicit Estimator(ml_estimator *owned) noexcept : est_(owned) {}
    Estimator(const Estimator &) = delete;
    Estimator &operator=(const Estimator &) = delete;
    /** Moves the handle; `other` is left empty. */
    Estimator(Estimator &&other) noexcept
        : est_(std::exchange(other.est_, nullptr)), keep_(std::move(other.keep_)) {}
    /** Frees this estimator, then takes `other`'s handle; `other` is left empty. */
    Estimator &operator=(Estimator &&other) noexcept {
        if (this != &other) {
            reset();
            est_ = std::exchange(other.est_, nullptr);
            keep_ = std::move(other.keep_);
        }
        return *this;
    }
    ~Estimator() { reset(); }

    /** The C handle (owned by this object; null when empty). */
    [[nodiscard]] ml_estimator *get() const noexcept { return est_; }
    /** True unless empty. */
    explicit operator bool() const noexcept { return est_ != nullptr; }

    /** `ml_estimator_create`: an estimator of `tree`'s lights. */
    [[nodiscard]] static Result<Estimator> try_create(const Tree &tree) {
        ml_estimator *e = nullptr;
        ml_status s = ml_estimator_create(tree.get(), &e);
        Estimator est(e);
        if (e != nullptr) est.keep_ = tree.keep_alive();
        return detail::result(s, std::move(est));
    }
    /** `ml_estimator_create`, throwing. */
    [[nodiscard]] static Estimator create(const Tree &tree) { return try_create(tree).value(); }

    /** `ml_estimator_set_point`: set up at `sp` for `technique` (`params` null: defaults). */
    Result<void> try_set_point(const ml_shading_point &sp, uint32_t technique,
                               const ml_direct_params *params = nullptr) {
        return detail::result(ml_estimator_set_point(est_, &sp, technique, params));
    }
    /** `ml_estimator_set_point`, throwing. */
    void set_point(const ml_shading_point &sp, uint32_t technique,
                   const ml_direct_params *params = nullptr) {
        try_set_point(sp, technique, params).value();
    }
    /**
     * `ml_estimator_set_visibility_cache`: learn with `cache` from the next `set_point` (null:
     * none). The estimator keeps the cache alive.
     */
    Result<void> try_set_visibility_cache(const VisibilityCache *cache) {
        return detail::result(
            ml_estimator_set_visibility_cache(est_, cache != nullptr ? cache->get() : nullptr));
    }
    /** `ml_estimator_set_visibility_cache`, throwing. */
    void set_visibility_cache(const VisibilityCache *cache) {
        try_set_visibility_cache(cache).value();
    }
    /** `ml_estimator_record`: the last light step's shadow ray was `visible` or not. */
    Result<void> try_record(bool visible) {
        return detail::result(ml_estimator_record(est_, visible ? 1u : 0u));
    }
    /** `ml_estimator_record`, throwing. */
    void record(bool visible) { try_record(visible).value(); }
    /** `ml_estimator_estimate`: one estimate (`visibility`, `uniforms` as `Tree::direct_estimate`). */
    template <class V, class U>
    [[nodiscard]] Result<ml_rgb64> try_estimate(V &&visibility, U &&uniforms) {
        ml_visibility slot{};
        const ml_visibility *vis = detail::c_visibility(visibility, slot);
        ml_uniforms u = detail::c_uniforms(uniforms);
        ml_rgb64 e{0.0, 0.0, 0.0};
        detail::CallScope scope;
        ml_status s = ml_estimator_estimate(est_, vis, &u, &e);
        scope.finish();
        return detail::result(s, e);
    }
    /** `ml_estimator_estimate`, throwing. */
    template <class V, class U>
    [[nodiscard]] ml_rgb64 estimate(V &&visibility, U &&uniforms) {
        return try_estimate(std::forward<V>(visibility), std::forward<U>(uniforms)).value();
    }
    /** `ml_estimator_start`: begins an estimate of the lower level. */
    Result<void> try_start() { return detail::result(ml_estimator_start(est_)); }
    /** `ml_estimator_start`, throwing. */
    void start() { try_start().value(); }
    /** `ml_estimator_next`: the next step (see `ml_step_kind`). */
    template <class U>
    [[nodiscard]] Result<ml_step> try_next(U &&uniforms) {
        ml_uniforms u = detail::c_uniforms(uniforms);
        ml_step step{};
        detail::CallScope scope;
        ml_status s = ml_estimator_next(est_, &u, &step);
        scope.finish();
        return detail::result(s, step);
    }
    /** `ml_estimator_next`, throwing. */
    template <class U>
    [[nodiscard]] ml_step next(U &&uniforms) {
        return try_next(std::forward<U>(uniforms)).value();
    }
    /** `ml_estimator_weigh`: the last light step's weight given the host's BSDF pdf. */
    [[nodiscard]] Result<ml_weighted> try_weigh(float bsdf_pdf) {
        ml_weighted w{};
        const ml_status s = ml_estimator_weigh(est_, bsdf_pdf, &w);
        return detail::result(s, w);
    }
    /** `ml_estimator_weigh`, throwing. */
    [[nodiscard]] ml_weighted weigh(float bsdf_pdf) { return try_weigh(bsdf_pdf).value(); }
    /**
     * `ml_estimator_bsdf_hits`: reports the last BSDF step's sample; `each(const ml_light_hit
     * &)` is called for every light reached. True if any was reached.
     */
    template <class F>
    [[nodiscard]] Result<bool> try_bsdf_hits(ml_vec3 direction, float bsdf_pdf,
                                             float hit_distance, F &&each) {
        using G = std::remove_reference_t<F>;
        uint32_t any = 0;
        detail::CallScope scope;
        ml_status s = ml_estimator_bsdf_hits(est_, direction, bsdf_pdf, hit_distance,
                                             &detail::hit_trampoline<G>, detail::user_data(each),
                                             &any);
        scope.finish();
        return detail::result(s, any != 0);
    }
    /** `ml_estimator_bsdf_hits`, throwing. */
    template <class F>
    bool bsdf_hits(ml_vec3 direction, float bsdf_pdf, float hit_distance, F &&each) {
        return try_bsdf_hits(direction, bsdf_pdf, hit_distance, std::forward<F>(each)).value();
    }

  private:
    void reset() noexcept {
        if (est_ != nullptr) (void)ml_estimator_free(est_);
        est_ = nullptr;
        keep_.reset();
    }
    ml_estimator *est_ = nullptr;
    std::shared_ptr<void> keep_;
};

// ---- VPL acceptance ------------------------------------------------------------------

/**
 * A VPL acceptor for one image (`ml_acceptor`): per-thread state (one per thread, their
 * counts added up by the host). One thread at a time. `visible(ml_vec3 importon, ml_vec3 vpl)`
 * callables return true if the segment between the points is unoccluded; the overloads
 * without one take every importon as visible.
 */
class Acceptor {
  public:
    /** An empty acceptor handle (`create` makes one). */
    Acceptor() noexcept = default;
    /** Takes ownership of a C acceptor. */
    explicit Acceptor(ml_acceptor *owned) noexcept : acc_(owned) {}
    Acceptor(const Acceptor &) = delete;
    Acceptor &operator=(const Acceptor &) = delete;
    /** Moves the handle; `other` is left empty. */
    Acceptor(Acceptor &&other) noexcept : acc_(std::exchange(other.acc_, nullptr)) {}
    /** Frees this acceptor, then takes `other`'s handle; `other` is left empty. */
    Acceptor &operator=(Acceptor &&other) noexcept {
        if (this != &other) {
            reset();
            acc_ = std::exchange(other.acc_, nullptr);
        }
        return *this;
    }
    ~Acceptor() { reset(); }

    /** The C handle (owned by this object; null when empty). */
    [[nodiscard]] ml_acceptor *get() const noexcept { return acc_; }
    /** True unless empty. */
    explicit operator bool() const noexcept { return acc_ != nullptr; }

    /** `ml_acceptor_create` (see `ml::acceptor_options`). */
    [[nodiscard]] static Result<Acceptor> try_create(const ml_acceptor_options &options) {
        ml_acceptor *a = nullptr;
        const ml_status s = ml_acceptor_create(&options, &a);
        return detail::result(s, Acceptor(a));
    }
    /** `ml_acceptor_create`, throwing. */
    [[nodiscard]] static Acceptor create(const ml_acceptor_options &options) {
        return try_create(options).value();
    }
    /** `ml_acceptor_set_importons`: replaces the importons. */
    Result<void> try_set_importons(Span<const ml_importon> importons) {
        return detail::result(
            ml_acceptor_set_importons(acc_, importons.data(), importons.size()));
    }
    /** `ml_acceptor_set_importons`, throwing. */
    void set_importons(Span<const ml_importon> importons) {
        try_set_importons(importons).value();
    }
    /** `ml_acceptor_update`: adds a frame's total VPL luminance to the running mean. */
    Result<void> try_update(double frame_luminance) {
        return detail::result(ml_acceptor_update(acc_, frame_luminance));
    }
    /** `ml_acceptor_update`, throwing. */
    void update(double frame_luminance) { try_update(frame_luminance).value(); }
    /** `ml_acceptor_set_total_luminance`: sets Φ̃_total. */
    Result<void> try_set_total_luminance(double total) {
        return detail::result(ml_acceptor_set_total_luminance(acc_, total));
    }
    /** `ml_acceptor_set_total_luminance`, throwing. */
    void set_total_luminance(double total) { try_set_total_luminance(total).value(); }
    /** `ml_acceptor_accept` with every importon visible. */
    [[nodiscard]] Result<ml_vpl_decision> try_accept(const ml_vpl &candidate, float xi) {
        ml_vpl_decision d{};
        const ml_status s = ml_acceptor_accept(acc_, &candidate, xi, nullptr, &d);
        return detail::result(s, d);
    }
    /** `ml_acceptor_accept` with the host's `visible(importon, vpl)`. */
    template <class F>
    [[nodiscard]] Result<ml_vpl_decision> try_accept(const ml_vpl &candidate, float xi,
                                                     F &&visible) {
        ml_vpl_visibility v{&detail::vpl_visible_trampoline<std::remove_reference_t<F>>,
                            detail::user_data(visible)};
        ml_vpl_decision d{};
        detail::CallScope scope;
        ml_status s = ml_acceptor_accept(acc_, &candidate, xi, &v, &d);
        scope.finish();
        return detail::result(s, d);
    }
    /** `ml_acceptor_accept` with every importon visible, throwing. */
    [[nodiscard]] ml_vpl_decision accept(const ml_vpl &candidate, float xi) {
        return try_accept(candidate, xi).value();
    }
    /** `ml_acceptor_accept` with the host's `visible`, throwing. */
    template <class F>
    [[nodiscard]] ml_vpl_decision accept(const ml_vpl &candidate, float xi, F &&visible) {
        return try_accept(candidate, xi, std::forward<F>(visible)).value();
    }
    /** `ml_acceptor_probability` with every importon visible. */
    [[nodiscard]] Result<float> try_probability(const ml_vpl &candidate) const {
        float p = 0.0f;
        const ml_status s = ml_acceptor_probability(acc_, &candidate, nullptr, &p);
        return detail::result(s, p);
    }
    /** `ml_acceptor_probability` with the host's `visible(importon, vpl)`. */
    template <class F>
    [[nodiscard]] Result<float> try_probability(const ml_vpl &candidate, F &&visible) const {
        ml_vpl_visibility v{&detail::vpl_visible_trampoline<std::remove_reference_t<F>>,
                            detail::user_data(visible)};
        float p = 0.0f;
        detail::CallScope scope;
        ml_status s = ml_acceptor_probability(acc_, &candidate, &v, &p);
        scope.finish();
        return detail::result(s, p);
    }
    /** `ml_acceptor_probability` with every importon visible, throwing. */
    [[nodiscard]] float probability(const ml_vpl &candidate) const {
        return try_probability(candidate).value();
    }
    /** `ml_acceptor_probability` with the host's `visible`, throwing. */
    template <class F>
    [[nodiscard]] float probability(const ml_vpl &candidate, F &&visible) const {
        return try_probability(candidate, std::forward<F>(visible)).value();
    }
    /** `ml_acceptor_stats`: the decisions counted. */
    [[nodiscard]] Result<ml_accept_stats> try_stats() const {
        ml_accept_stats st{};
        const ml_status s = ml_acceptor_stats(acc_, &st);
        return detail::result(s, st);
    }
    /** `ml_acceptor_stats`, throwing. */
    [[nodiscard]] ml_accept_stats stats() const { return try_stats().value(); }
    /** `ml_acceptor_reset_stats`: zeroes the counts. */
    Result<void> try_reset_stats() { return detail::result(ml_acceptor_reset_stats(acc_)); }
    /** `ml_acceptor_reset_stats`, throwing. */
    void reset_stats() { try_reset_stats().value(); }

  private:
    void reset() noexcept {
        if (acc_ != nullptr) (void)ml_acceptor_free(acc_);
        acc_ = nullptr;
    }
    ml_acceptor *acc_ = nullptr;
};

}  // namespace ml

#endif  // MANYLIGHTS_HPP
