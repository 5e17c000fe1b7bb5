//! The C ABI (`manylights-ffi`) called from Rust as a host would call it, with arbitrary
//! arguments: a sequence of operations on handles the harness keeps (trees built from light
//! descriptors of every kind, serially or in parallel, with or without an environment (a
//! light of kind 7 among the drawn ones stands for it, or a drawn `ml_environment`: bounds,
//! NULL callbacks and bad values from them included), or loaded from serialized bytes, with
//! or without their lights, edited or not; cuts; estimators; VPL acceptors; visibility
//! caches, given to estimators), each pointer argument NULL, valid or misaligned, each value
//! raw or in range, each count at most the length of the buffer behind it (the ABI trusts a pointer and count
//! the host passes: only NULL pointers go with larger counts), light indices in or out of
//! range. Freed handles are never used again. After every call:
//!
//! - the status is one of `ML_OK` … `ML_ERR_STATE`: `ML_ERR_INTERNAL` (a caught panic or a
//!   broken invariant) and any other value are findings;
//! - on failure no output was written (every output is pre-filled with a sentinel) and
//!   `ml_last_error_message()` starts with the function's name and says something;
//! - on success no misaligned pointer was accepted, no output is NaN, a sampled light is in
//!   range with pmf in (0, 1] (`ML_NO_LIGHT` with pmf 0), pmfs are in [0, 1], estimates and
//!   MIS scales are finite and non-negative, weights in [0, 1], a batch (samples and pmfs,
//!   points on lights, estimates) leaves the elements past its count alone and equals the
//!   single calls bit for bit (the estimates drawing the same uniform numbers), and with valid
//!   arrays a batch fails only where one of its single calls fails; the unedited bytes of a
//!   serialized tree load back, with the lights of their tree too, giving a tree that
//!   serializes to the same bytes and answers the pmfs, samples and points on lights of the
//!   tree they were saved from bit for bit; the parallel build gives `ml_tree_build`'s status
//!   and tree, byte for byte; a build or load with the environment's bounds not finite, negative or
//!   above `ML_MAX_LIGHT_ENERGY` fails; on a tree with an environment, a call during which
//!   its callbacks returned a bad value (a NaN, negative or infinite radiance or pdf, a pdf
//!   of 0 or a zero direction from `sample`) is `ML_ERR_INVALID_ARGUMENT` and no other call's
//!   message blames the environment, and the environment's points (its samples from
//!   `ml_light_sample_point`, the batch and the light steps, an escaping BSDF ray's hit, and
//!   only an escaping ray's) carry its radiance and pdf at distance +∞, its sample's
//!   `ml_light_pdf_point` being `eval`'s pdf; `ml_light_sample_point_batch` may have written
//!   the points before a bad sample.
//!
//! The module's parts: `grammar` decodes the fuzzer's bytes into the operations (the
//! [`Input`] a target takes) and their values into the ABI's arguments; `buffers` holds the
//! arguments behind aligned, misaligned or NULL pointers, every output pre-filled with a
//! sentinel; `host` provides the callbacks (uniform numbers, visibility, hits, an
//! environment); `harness` keeps the handles, replays the operations, one module a family of
//! the ABI, and makes the checks above ([`check`]).

mod buffers;
mod grammar;
mod harness;
mod host;

pub use grammar::*;
pub use harness::check;

impl crate::Checked for Input {
    fn check(&self) {
        check(self)
    }
}

#[cfg(test)]
mod tests {
    /// splitmix64 bytes (the low byte of each output, from the state `seed`).
    fn bytes(seed: u64, len: usize) -> Vec<u8> {
        let mut rng = manylights_testkit::SplitMix64(seed);
        (0..len).map(|_| rng.next_u64() as u8).collect()
    }

    /// Twelve lights of every kind, then the same with an environment (a thirteenth light of
    /// kind 7), through the operations of the builds, the loads with lights, the points on
    /// lights (the environment's included), the estimate batches, builds with a drawn
    /// environment and estimates and step loops on them, with valid arguments, every
    /// technique: the checks pass (on the deep paths random bytes seldom reach).
    #[test]
    fn valid_scene_passes() {
        use super::grammar::*;
        let s = |k: i16| F::Small(k);
        let light = |kind: u8, z: i16| Light {
            kind: Enum(kind),
            two_sided: Enum(0),
            position: [s(64), s(-32), s(z)],
            direction: [s(0), s(0), s(-256)],
            vertex2: [s(256), s(0), s(z)],
            power: s(256),
            radius: s(32),
            half_angle: s(200),
            falloff_start: F::Unit(32768),
        };
        let lights: Vec<Light> = (0..12)
            .map(|i| light([0, 1, 2, 3, 4, 5, 6][i % 7], 256 + 64 * i as i16))
            .chain([light(7, 0)])
            .collect();
        let sp = Sp {
            position: [s(0), s(0), s(0)],
            normal: [s(0), s(0), s(256)],
            wo: [s(40), s(0), s(256)],
            material: MaterialDesc {
                kind: Enum(2),
                albedo: F::Unit(32768),
                specular: F::Unit(32768),
                alpha: F::Unit(20000),
            },
        };
        let tl = TlPoint {
            position: sp.position,
            normal: sp.normal,
            receiver: Enum(0),
        };
        let uni = Uniforms {
            no_f32: Rare(0),
            f64: true,
            raw: Rare(0),
            values: vec![],
        };
        let env = EnvDesc {
            no_sample: Rare(0),
            no_eval: Rare(0),
            radiance: s(128),
            misses: vec![false, false, true],
            raw: Rare(0),
            pdf: F::Unit(0),
            zero: Rare(0),
        };
        fn arg<T>(value: T) -> Arg<T> {
            Arg {
                ptr: Ptr::Valid,
                value,
            }
        }
        let mut ops = Vec::new();
        for n in [12, 13] {
            let ls = lights[..n].to_vec();
            ops.push(Op::Build {
                lights: ls.clone(),
                count: Count::All,
                ptr: Ptr::Valid,
                options: None,
                out: Ptr::Valid,
            });
            ops.push(Op::BuildParallel {
                lights: ls,
                count: Count::All,
                ptr: Ptr::Valid,
                options: None,
                threads: Threads(2),
                out: Ptr::Valid,
            });
            ops.push(Op::Serialize {
                tree: Handle::Live(0),
                capacity: Capacity::Exact,
                buffer: Ptr::Valid,
                written: Ptr::Valid,
            });
            ops.push(Op::LoadWithLights {
                bytes: Bytes::Serialized {
                    edits: vec![],
                    keep: None,
                },
                lights: LightsArg::Own,
                count: Count::All,
                ptrs: [Ptr::Valid; 2],
                out: Ptr::Valid,
                points: vec![tl; 2],
                sps: vec![sp; 2],
            });
            ops.push(Op::LoadWithLights {
                bytes: Bytes::Serialized {
                    edits: vec![],
                    keep: None,
                },
                lights: LightsArg::Edited(vec![(3, light(0, 9000))]),
                count: Count::All,
                ptrs: [Ptr::Valid; 2],
                out: Ptr::Valid,
                points: vec![],
                sps: vec![],
            });
            ops.push(Op::FreeTree(Handle::Live(0)));
            ops.push(Op::LoadWithLights {
                bytes: Bytes::Serialized {
                    edits: vec![],
                    keep: None,
                },
                lights: LightsArg::Own,
                count: Count::All,
                ptrs: [Ptr::Valid; 2],
                out: Ptr::Valid,
                points: vec![tl],
                sps: vec![sp],
            });
            ops.push(Op::LightSamplePointBatch {
                tree: Handle::Live(0),
                xs: vec![tl.position; 5],
                lights: (0..5).map(Index::In).collect(),
                u0s: vec![F::Unit(100), F::Unit(30000)],
                u1s: vec![F::Unit(60000)],
                count: Count::All,
                ptrs: [Ptr::Valid; 5],
            });
            for technique in 0..10 {
                ops.push(Op::DirectEstimateBatch {
                    tree: Handle::Live(0),
                    points: vec![sp; 3],
                    count: Count::All,
                    per_point: technique % 2,
                    technique: Enum(technique),
                    params: None,
                    visibility: Some(arg(Visibility {
                        occluded: Some(vec![false, true, false]),
                        first_hit: None,
                    })),
                    uniforms: arg(uni.clone()),
                    ptrs: [Ptr::Valid; 2],
                });
                ops.push(Op::EnvBuild {
                    tree: Handle::Live(0),
                    sp: arg(sp),
                    technique: Enum(technique),
                    params: None,
                    visibility: None,
                    environment: Some(arg(env.clone())),
                    uniforms: arg(uni.clone()),
                    out: Ptr::Valid,
                });
                ops.push(Op::RunEnv {
                    tree: Handle::Live(0),
                    sp,
                    technique: Enum(technique),
                    params: None,
                    uniforms: uni.clone(),
                    visibility: None,
                    environment: env.clone(),
                    distances: vec![F::Special(1)],
                    keep: true,
                });
                ops.push(Op::EstimateEnv {
                    est: Handle::Live(0),
                    visibility: None,
                    environment: Some(arg(env.clone())),
                    uniforms: arg(uni.clone()),
                    out: Ptr::Valid,
                });
                ops.push(Op::EstimatorFree(Handle::Live(0)));
            }
            ops.push(Op::FreeTree(Handle::Live(0)));
            ops.push(Op::FreeTree(Handle::Live(0)));
            ops.push(Op::FreeTree(Handle::Live(0)));
        }
        assert!(ops.len() <= 2 * super::grammar::MAX_OPS);
        for half in ops.chunks(ops.len() / 2) {
            super::check(&super::Input { ops: half.to_vec() });
        }
    }

    /// Trees with environments whose callbacks return bad values (a NaN, negative or
    /// infinite radiance, a NaN or zero pdf, a zero direction) or are NULL, and bad bounds:
    /// every technique's one call, batch, step loop, escaping BSDF rays and points on the
    /// environment pass the checks (a call that got a bad value is `ML_ERR_INVALID_ARGUMENT`,
    /// no other blames the environment).
    #[test]
    fn bad_environments_pass() {
        use super::grammar::*;
        let s = |k: i16| F::Small(k);
        let light = |kind: u8, z: i16| Light {
            kind: Enum(kind),
            two_sided: Enum(0),
            position: [s(64), s(-32), s(z)],
            direction: [s(0), s(0), s(-256)],
            vertex2: [s(256), s(0), s(z)],
            power: s(256),
            radius: s(32),
            half_angle: s(200),
            falloff_start: F::Unit(32768),
        };
        let lights: Vec<Light> = (0..8)
            .map(|i| light([0, 1, 2, 3, 4, 5, 6][i % 7], 256 + 64 * i as i16))
            .collect();
        let sp = Sp {
            position: [s(0), s(0), s(0)],
            normal: [s(0), s(0), s(256)],
            wo: [s(40), s(0), s(256)],
            material: MaterialDesc {
                kind: Enum(0),
                albedo: F::Unit(32768),
                specular: F::Unit(0),
                alpha: F::Unit(20000),
            },
        };
        let uni = Uniforms {
            no_f32: Rare(0),
            f64: true,
            raw: Rare(0),
            values: vec![],
        };
        fn arg<T>(value: T) -> Arg<T> {
            Arg {
                ptr: Ptr::Valid,
                value,
            }
        }
        let env = |radiance: F, pdf: F, zero: u8, no: [u8; 2]| EnvDesc {
            no_sample: Rare(no[0]),
            no_eval: Rare(no[1]),
            radiance,
            misses: vec![false, true, false],
            raw: Rare(255),
            pdf,
            zero: Rare(zero),
        };
        let envs = [
            env(F::Special(0), F::Unit(1000), 0, [0, 0]),
            env(F::Small(-256), F::Unit(1000), 0, [0, 0]),
            env(F::Special(1), F::Unit(1000), 0, [0, 0]),
            env(s(64), F::Special(0), 0, [0, 0]),
            env(s(64), F::Unit(0), 0, [0, 0]),
            env(s(64), F::Unit(1000), 255, [0, 0]),
            env(s(64), F::Unit(1000), 0, [255, 0]),
            env(s(64), F::Unit(1000), 0, [0, 255]),
            env(F::Special(7), F::Unit(1000), 0, [0, 0]),
            env(s(64), F::Unit(1000), 0, [0, 0]),
        ];
        for e in &envs {
            let mut ops = vec![Op::Build {
                lights: lights.clone(),
                count: Count::All,
                ptr: Ptr::Valid,
                options: None,
                out: Ptr::Valid,
            }];
            for technique in 0..10 {
                ops.push(Op::EnvBuild {
                    tree: Handle::Live(0),
                    sp: arg(sp),
                    technique: Enum(technique),
                    params: None,
                    visibility: None,
                    environment: Some(arg(e.clone())),
                    uniforms: arg(uni.clone()),
                    out: Ptr::Valid,
                });
                ops.push(Op::DirectEstimateBatch {
                    tree: Handle::Live(1),
                    points: vec![sp; 2],
                    count: Count::All,
                    per_point: technique % 3,
                    technique: Enum(technique),
                    params: None,
                    visibility: None,
                    uniforms: arg(uni.clone()),
                    ptrs: [Ptr::Valid; 2],
                });
                ops.push(Op::LightSamplePointBatch {
                    tree: Handle::Live(1),
                    xs: vec![sp.position; 4],
                    lights: vec![Index::In(8), Index::In(1), Index::In(8), Index::In(3)],
                    u0s: vec![F::Unit(100), F::Unit(30000), F::Unit(50000)],
                    u1s: vec![F::Unit(60000), F::Unit(7)],
                    count: Count::All,
                    ptrs: [Ptr::Valid; 5],
                });
                ops.push(Op::RunEnv {
                    tree: Handle::Live(0),
                    sp,
                    technique: Enum(technique),
                    params: None,
                    uniforms: uni.clone(),
                    visibility: None,
                    environment: e.clone(),
                    distances: vec![F::Special(1), s(256)],
                    keep: true,
                });
                ops.push(Op::BsdfHitsEnv {
                    est: Handle::Live(0),
                    direction: [s(0), s(0), s(256)],
                    bsdf_pdf: F::Unit(20000),
                    hit_distance: s(256),
                    environment_pdf: F::Unit(0),
                    no_each: Rare(0),
                    any_hit: Ptr::Valid,
                });
                ops.push(Op::EstimatorFree(Handle::Live(0)));
                ops.push(Op::FreeTree(Handle::Live(1)));
                ops.push(Op::FreeTree(Handle::Live(1)));
            }
            for chunk in ops[1..].chunks(16) {
                let mut input = vec![ops[0].clone()];
                input.extend_from_slice(chunk);
                super::check(&super::Input { ops: input });
            }
        }
    }

    /// The `.rs` files of `dir`, concatenated.
    fn sources(dir: &std::path::Path) -> String {
        let mut files: Vec<_> = std::fs::read_dir(dir)
            .expect("a source directory")
            .map(|e| e.expect("a readable directory").path())
            .filter(|p| p.extension().is_some_and(|x| x == "rs"))
            .collect();
        files.sort();
        files
            .iter()
            .map(|f| std::fs::read_to_string(f).expect("a readable source"))
            .collect()
    }

    /// Every function the C ABI exports (`pub extern "C" fn` in `ffi/src/`) is called by the
    /// harness (named in `harness/`, as a whole word).
    #[test]
    fn every_abi_function_is_driven() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let ffi = sources(&dir.join("../../ffi/src"));
        let harness = sources(&dir.join("src/ffi/harness"));
        let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
        let named = |name: &str| {
            harness.match_indices(name).any(|(i, _)| {
                let before = harness[..i].chars().next_back().is_none_or(|c| !ident(c));
                let after = harness[i + name.len()..]
                    .chars()
                    .next()
                    .is_none_or(|c| !ident(c));
                before && after
            })
        };
        let exported: Vec<&str> = ffi
            .split("pub extern \"C\" fn ")
            .skip(1)
            .map(|rest| rest.split(|c: char| !ident(c)).next().unwrap_or(""))
            .collect();
        assert!(exported.len() > 50, "{} exported functions", exported.len());
        let missing: Vec<&str> = exported.into_iter().filter(|n| !named(n)).collect();
        assert!(missing.is_empty(), "not called by the harness: {missing:?}");
    }

    /// Seeded inputs of every length up to 4 KiB pass the checks (the harness itself works:
    /// the committed crash inputs are replayed by `tests/regressions.rs`).
    #[test]
    fn seeded_inputs_pass() {
        for seed in 0..300u64 {
            let b = bytes(seed, (seed as usize * 37) % 4096);
            assert!(crate::run::<super::Input>(&b), "seed {seed}: not decoded");
        }
    }

    /// The cut calls on trees with lights at infinity (a sun alone; a sun and an environment
    /// beside local lights), BRDF-oriented and split, with valid arguments: the checks pass (a
    /// light at infinity sampled in its own cluster, found there by `ml_cut_pmf_in`).
    #[test]
    fn cuts_with_lights_at_infinity_pass() {
        use super::grammar::*;
        let s = |k: i16| F::Small(k);
        let light = |kind: u8, z: i16| Light {
            kind: Enum(kind),
            two_sided: Enum(0),
            position: [s(64), s(-32), s(z)],
            direction: [s(40), s(-20), s(256)],
            vertex2: [s(256), s(0), s(z)],
            power: s(256),
            radius: s(32),
            half_angle: s(2),
            falloff_start: F::Unit(32768),
        };
        let sp = Sp {
            position: [s(0), s(0), s(0)],
            normal: [s(0), s(0), s(256)],
            wo: [s(40), s(0), s(256)],
            material: MaterialDesc {
                kind: Enum(2),
                albedo: F::Unit(32768),
                specular: F::Unit(32768),
                alpha: F::Unit(20000),
            },
        };
        let tl = TlPoint {
            position: sp.position,
            normal: sp.normal,
            receiver: Enum(0),
        };
        fn arg<T>(value: T) -> Arg<T> {
            Arg {
                ptr: Ptr::Valid,
                value,
            }
        }
        let scenes: [Vec<Light>; 2] = [
            vec![light(6, 0)],
            (0..6)
                .map(|i| light(i, 256 + 64 * i as i16))
                .chain([light(6, 0), light(7, 0)])
                .collect(),
        ];
        for lights in scenes {
            let n = lights.len() as u16;
            let mut ops = vec![
                Op::Build {
                    lights,
                    count: Count::All,
                    ptr: Ptr::Valid,
                    options: None,
                    out: Ptr::Valid,
                },
                Op::CutCreate { out: Ptr::Valid },
            ];
            for bl in [true, false] {
                ops.push(if bl {
                    Op::CutBuild {
                        cut: Handle::Live(0),
                        tree: Handle::Live(0),
                        sp: arg(sp),
                        options: None,
                    }
                } else {
                    Op::CutBuildSplit {
                        cut: Handle::Live(0),
                        tree: Handle::Live(0),
                        point: arg(tl),
                        options: None,
                    }
                });
                ops.push(Op::CutSize {
                    cut: Handle::Live(0),
                    out: Ptr::Valid,
                });
                for k in [0u16, 20000, 40000, 65535] {
                    ops.push(Op::CutSample {
                        cut: Handle::Live(0),
                        u: F::Unit(k),
                        out: Ptr::Valid,
                    });
                }
                for l in 0..n {
                    ops.push(Op::CutPmf {
                        cut: Handle::Live(0),
                        light: Index::In(l),
                        out: Ptr::Valid,
                    });
                    ops.push(Op::CutPmfIn {
                        cut: Handle::Live(0),
                        light: Index::In(l),
                        ptrs: [Ptr::Valid; 2],
                    });
                }
                ops.push(Op::CutSampleClusters {
                    cut: Handle::Live(0),
                    us: vec![F::Unit(12345), F::Unit(54321), F::Unit(3)],
                    count: Count::All,
                    ptrs: [Ptr::Valid; 2],
                });
            }
            ops.push(Op::CutFree(Handle::Live(0)));
            ops.push(Op::FreeTree(Handle::Live(0)));
            assert!(ops.len() <= super::grammar::MAX_OPS);
            super::check(&super::Input { ops });
        }
    }
    /// A visibility cache on a tree of lights of every kind, given to an estimator: passes of
    /// set-ups and estimates (one call and step loop, recorded) with commits, statistics and
    /// sizes, bad options, another tree's cache, the cache freed before the estimator, with
    /// valid arguments: the checks pass.
    #[test]
    fn visibility_caches_pass() {
        use super::grammar::*;
        let s = |k: i16| F::Small(k);
        let light = |kind: u8, z: i16| Light {
            kind: Enum(kind),
            two_sided: Enum(0),
            position: [s(z / 4), s(-32), s(z)],
            direction: [s(0), s(0), s(-256)],
            vertex2: [s(256), s(0), s(z)],
            power: s(256),
            radius: s(32),
            half_angle: s(200),
            falloff_start: F::Unit(32768),
        };
        let lights: Vec<Light> = (0..24)
            .map(|i| light([0, 1, 2, 3, 4, 5][i % 6], 256 + 64 * i as i16))
            .collect();
        let sp = Sp {
            position: [s(0), s(0), s(0)],
            normal: [s(0), s(0), s(256)],
            wo: [s(40), s(0), s(256)],
            material: MaterialDesc {
                kind: Enum(2),
                albedo: F::Unit(32768),
                specular: F::Unit(32768),
                alpha: F::Unit(20000),
            },
        };
        let uni = Uniforms {
            no_f32: Rare(0),
            f64: true,
            raw: Rare(0),
            values: vec![],
        };
        fn arg<T>(value: T) -> Arg<T> {
            Arg {
                ptr: Ptr::Valid,
                value,
            }
        }
        let opts = |cells: u8, floor: Option<F>| CacheOpts {
            cell_size: s(256),
            cells: CacheSize(cells),
            slots: CacheSize(16),
            floor,
        };
        let build = Op::Build {
            lights,
            count: Count::All,
            ptr: Ptr::Valid,
            options: None,
            out: Ptr::Valid,
        };
        let create = |tree: u8, o: CacheOpts| Op::CacheCreate {
            tree: Handle::Live(tree),
            options: arg(o),
            out: Ptr::Valid,
        };
        let call = |c: u8, call: CacheCall| Op::Cache {
            cache: Handle::Live(c),
            call,
        };
        let mut ops = vec![
            build.clone(),
            build,
            create(0, opts(3, None)),
            create(0, opts(255, None)),
            create(0, opts(32, Some(F::Special(3)))),
            create(0, opts(32, None)),
            create(1, opts(8, Some(F::Unit(30000)))),
            Op::EstimatorCreate {
                tree: Handle::Live(0),
                out: Ptr::Valid,
            },
            Op::SetCache {
                est: Handle::Live(0),
                cache: Handle::Live(1),
            },
            Op::SetCache {
                est: Handle::Live(0),
                cache: Handle::Live(0),
            },
        ];
        for technique in [8, 6, 4] {
            ops.push(Op::SetPoint {
                est: Handle::Live(0),
                sp: arg(sp),
                technique: Enum(technique),
                params: None,
            });
            for _ in 0..3 {
                ops.push(Op::Estimate {
                    est: Handle::Live(0),
                    visibility: None,
                    uniforms: arg(uni.clone()),
                    out: Ptr::Valid,
                });
            }
            ops.push(Op::Start(Handle::Live(0)));
            for visible in [2, 1, 0] {
                ops.push(Op::Next {
                    est: Handle::Live(0),
                    uniforms: arg(uni.clone()),
                    out: Ptr::Valid,
                });
                ops.push(Op::Record {
                    est: Handle::Live(0),
                    visible,
                });
            }
            ops.push(call(0, CacheCall::Commit));
            ops.push(call(0, CacheCall::Stats(Ptr::Valid)));
        }
        ops.extend([
            call(0, CacheCall::Bytes(Ptr::Valid)),
            call(0, CacheCall::Bytes(Ptr::Misaligned)),
            call(0, CacheCall::SetRecording(2)),
            call(0, CacheCall::SetRecording(0)),
            call(0, CacheCall::Clear),
            call(0, CacheCall::Stats(Ptr::Null)),
            Op::CacheFree(Handle::Live(0)),
            Op::SetPoint {
                est: Handle::Live(0),
                sp: arg(sp),
                technique: Enum(8),
                params: None,
            },
            Op::Estimate {
                est: Handle::Live(0),
                visibility: None,
                uniforms: arg(uni),
                out: Ptr::Valid,
            },
            Op::SetCache {
                est: Handle::Live(0),
                cache: Handle::Null,
            },
            Op::EstimatorFree(Handle::Live(0)),
            Op::FreeTree(Handle::Live(0)),
        ]);
        assert!(ops.len() <= super::grammar::MAX_OPS);
        super::check(&super::Input { ops });
    }
}
