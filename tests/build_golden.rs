//! The build's choices, pinned: for seeded scenes of every light kind and layout, the hash of
//! the binary SAOH tree (each node's bounds, energy and child, as the baseline stores them),
//! of the finished 4-wide tree's contents (nodes, node variances, each light slot's light and
//! each light's path, read through the public accessors, so independent of how they are
//! stored) built with the default options and with `compact`, and of the default tree's byte
//! form ([`manylights::LightTree::as_bytes`]), which alone changes with the byte format. A
//! change to a split, a bound, a slot or a code shows here; one that is meant must record new
//! hashes: run `GOLDEN_PRINT=1 cargo test --test build_golden -- --nocapture` and paste the
//! printed rows over `RECORDED`.
//!
//! The parallel build ([`LightTree::build_parallel`]) is checked against the serial one, byte
//! for byte, with a fork-join on threads of its own.

mod golden;

use manylights::{BuildOptions, Join, LightTree};
use std::sync::atomic::{AtomicUsize, Ordering};

/// (seed, lights, style, binary tree, 4-wide tree's contents, the same with `compact`, 4-wide
/// tree's bytes).
#[rustfmt::skip]
const RECORDED: [(u64, usize, u32, u64, u64, u64, u64); 24] = [
    (1, 1, 0, 0xb122d32dfb68399c, 0x748c1ad283d94b2f, 0x748c1ad283d94b2f, 0x28c434386b2c2ae1),
    (2, 2, 0, 0xde098cc63362214b, 0xba8f2445da67f6dd, 0xba8f2445da67f6dd, 0xa64cf5a37c02fde6),
    (3, 3, 1, 0x8f1e07c63048e43a, 0xd4c83797774b9548, 0xd4c83797774b9548, 0x17eecee1e3b9f8e2),
    (4, 4, 0, 0xcd3c0b928ae3a0c6, 0xb6c5246b442a05e4, 0xb6c5246b442a05e4, 0xa190e0e8b85b8243),
    (5, 5, 4, 0xec238fdacbe6fa3a, 0x5e31b0c83ed4b9c5, 0x5e31b0c83ed4b9c5, 0xb09a98fc6ebcd0f0),
    (6, 6, 2, 0x88226e288a4f1d23, 0x043bdeef76136719, 0x01b5995b590a04bf, 0x42e358eeb3c7e1e7),
    (7, 9, 3, 0x561fc35e1399c573, 0x83b01a03d3dcf63e, 0x83b01a03d3dcf63e, 0xafb72b45961bfa21),
    (8, 17, 0, 0xad5980bae3f7c678, 0x3cc0762db53de479, 0x78fc043992603aac, 0xfa56cef6ca0f12d5),
    (9, 33, 1, 0x312b44605d5d8a8f, 0x93775324ff7591ea, 0x2d39d37c1cfd21cb, 0x138b6b9166568ac6),
    (10, 100, 0, 0xce28469c8b9a305a, 0x79d024d160a4dcb8, 0x5e928327d20ae2bd, 0x235619e103aef383),
    (11, 100, 4, 0xf8cf481fdd286fdf, 0xd2d7af307e129824, 0x8cccc33af855cfc6, 0xe2d8099685997bb7),
    (12, 300, 2, 0x04212d44d0daf686, 0x72c158079635f0b1, 0x2d3d5b4ee9adddb3, 0x475372b04c7eec38),
    (13, 300, 3, 0x6b2a002ff88af45f, 0x85617703c04a7eef, 0xfa179e0d079989f5, 0xae7f5d65d8b3800c),
    (14, 1000, 0, 0x068ca093a51d25fa, 0xf4e187b4884da206, 0x450a619eedacefbe, 0x30a09be9f38aa127),
    (15, 1000, 1, 0x96b3d01cabc076cc, 0xf70c06f7be200291, 0x2371055ea3821803, 0xf300153b2c6cb3ce),
    (16, 1000, 4, 0x26871a88b0aa92e4, 0x6d048975e777a963, 0x9a603bfb49ea8078, 0x4bab05bb3116f5e7),
    (17, 3000, 2, 0x774b024c08732345, 0x639d90672a2e77d7, 0x67c9277010dd7a0f, 0xb50fb177a39bdac0),
    (18, 3000, 3, 0x739dd3daabbbcbfd, 0x6357258e63bd0051, 0x00e84b796df847f9, 0xdf175d3a2872a614),
    (19, 5000, 0, 0x9e53dc548d12a3a0, 0xd2e98ba995256ca0, 0x2499c40fb49ffcb8, 0xea875dd52124438a),
    (20, 5000, 1, 0xf6571d0ccb22a177, 0x8a391e3b883424da, 0xe3643d88ea3656b9, 0x5b0501b986e4ba8a),
    (21, 20000, 0, 0x1a25cf3abbd34d93, 0x0cd2fa1645fd9fc1, 0xafc44f517878c377, 0x697283c4a15aad2f),
    (22, 20000, 1, 0x1c73193f5edb91eb, 0x38f86a545dc41830, 0xbfdc56cb5fcafd37, 0xc09c138ee05a82d3),
    (23, 20000, 4, 0xa6f9a1ee2bd1cff1, 0x3aa28bb460607e86, 0x6c1d27444c548b9b, 0x7a6436f44483de28),
    (24, 20000, 3, 0xc549aa0bbada8b66, 0x66bedc81c4b4c40b, 0x23ee7252292e41a4, 0x1524ede9f34a42fd),
];

#[test]
fn binary_and_4_wide_trees_are_the_recorded_ones() {
    let print = std::env::var_os("GOLDEN_PRINT").is_some();
    let mut wrong = Vec::new();
    for (&(seed, n, style), &(rs, rn, rst, bin, tree, compact, bytes)) in
        golden::CASES.iter().zip(&RECORDED)
    {
        assert_eq!(
            (seed, n, style),
            (rs, rn, rst),
            "cases and records out of step"
        );
        let lights = golden::scene(seed, n, style);
        let got = golden::hashes(&lights);
        if print {
            let [b, t, c, y] = got;
            println!("    ({seed}, {n}, {style}, 0x{b:016x}, 0x{t:016x}, 0x{c:016x}, 0x{y:016x}),");
        }
        let want = [bin, tree, compact, bytes];
        if got != want {
            let same = |i: usize| if got[i] == want[i] { "same" } else { "differs" };
            wrong.push(format!(
                "seed {seed}, {n} lights, style {style}: binary {}, 4-wide {}, compact {}, bytes {}",
                same(0),
                same(1),
                same(2),
                same(3)
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// A fork-join that runs `b` on a scoped thread of its own while `a` runs on the caller's, and
/// counts its calls.
#[derive(Default)]
struct Threads {
    calls: AtomicUsize,
}

impl Join for Threads {
    fn join<A, B, RA, RB>(&self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA + Send,
        B: FnOnce() -> RB + Send,
        RA: Send,
        RB: Send,
    {
        self.calls.fetch_add(1, Ordering::Relaxed);
        std::thread::scope(|s| {
            let hb = s.spawn(b);
            let ra = a();
            (ra, hb.join().expect("the other half of the build ran"))
        })
    }
}

#[test]
fn parallel_build_is_the_serial_one_byte_for_byte() {
    // Sizes around and well above the smallest split subtree (2^14 lights), every layout,
    // with and without `compact`.
    for (seed, n, style) in [
        (31, 18_000, 0),
        (32, 20_000, 1),
        (33, 40_000, 2),
        (34, 70_000, 3),
        (35, 100_000, 4),
    ] {
        let lights = golden::scene(seed, n, style);
        for compact in [false, true] {
            let opts = BuildOptions {
                compact,
                ..BuildOptions::default()
            };
            let serial = LightTree::build_with(&lights, &opts).expect("valid scene");
            let join = Threads::default();
            let parallel = LightTree::build_parallel(&lights, &opts, &join).expect("valid scene");
            assert!(
                join.calls.load(Ordering::Relaxed) >= 2,
                "{n} lights, style {style}: the build was not split"
            );
            assert!(
                parallel.as_bytes() == serial.as_bytes(),
                "{n} lights, style {style}, compact {compact}: the parallel tree differs"
            );
        }
    }
    // The mixed scene of the benches.
    let lights = manylights_testkit::lights(60_000, 5);
    let serial = LightTree::build(&lights).expect("valid scene");
    let parallel =
        LightTree::build_parallel(&lights, &BuildOptions::default(), &Threads::default())
            .expect("valid scene");
    assert!(parallel.as_bytes() == serial.as_bytes());
}
