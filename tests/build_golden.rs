//! The build's choices, pinned: for seeded scenes of every light kind and layout, the hash of
//! the binary SAOH tree (each node's bounds, energy and child, as the baseline stores them)
//! and of the finished 4-wide tree's bytes ([`manylights::LightTree::as_bytes`]), built with
//! the default options and with `compact`. The binary hashes are the ones recorded with the
//! build of commit 7760e2d, before the build's memory layout and speed work; the 4-wide ones
//! were recorded with commit 033bbe1 (`main`: 64-byte quantised nodes, format version 2, the
//! collapse with free-form packing), whose build this one reproduces bit for bit. A change to
//! a split, a bound, a slot or a code shows here; one that is meant must record new hashes
//! (run with `GOLDEN_PRINT=1` and `--nocapture`).

mod golden;

/// (seed, lights, style, binary tree, 4-wide tree, 4-wide tree with `compact`).
#[rustfmt::skip]
const RECORDED: [(u64, usize, u32, u64, u64, u64); 24] = [
    (1, 1, 0, 0xb122d32dfb68399c, 0x2e427b609cc97014, 0x2e427b609cc97014),
    (2, 2, 0, 0xde098cc63362214b, 0x1efffe996bfd7dfa, 0x1efffe996bfd7dfa),
    (3, 3, 1, 0x8f1e07c63048e43a, 0xa13c51272b2ed42f, 0xa13c51272b2ed42f),
    (4, 4, 0, 0xcd3c0b928ae3a0c6, 0x26863986529d8767, 0x26863986529d8767),
    (5, 5, 4, 0xec238fdacbe6fa3a, 0x13eb9db296e952f6, 0x13eb9db296e952f6),
    (6, 6, 2, 0x88226e288a4f1d23, 0x5706ebe6a416f29a, 0xb8a1f70bc9956f94),
    (7, 9, 3, 0x561fc35e1399c573, 0xe055b7249518ecec, 0xe055b7249518ecec),
    (8, 17, 0, 0xad5980bae3f7c678, 0xd73d29de1c0e223a, 0x6be046a64e6ed5ed),
    (9, 33, 1, 0x312b44605d5d8a8f, 0xadfb257e06a4b224, 0x6922e5995521903a),
    (10, 100, 0, 0xce28469c8b9a305a, 0x40b1e4a68c0f6979, 0x5cb2fa2f7b77a81b),
    (11, 100, 4, 0xf8cf481fdd286fdf, 0xe17eaa794c42b455, 0xb38781f64360403b),
    (12, 300, 2, 0x04212d44d0daf686, 0x85a9896976f4d043, 0x02d185896043f652),
    (13, 300, 3, 0x6b2a002ff88af45f, 0x678197094196e74b, 0xae8e14d22a1aa2a9),
    (14, 1000, 0, 0x068ca093a51d25fa, 0xbbe4027cafb8af5d, 0xc412642f17e3e9be),
    (15, 1000, 1, 0x96b3d01cabc076cc, 0x515aa1e14467279e, 0x8ab484d91a9c324b),
    (16, 1000, 4, 0x26871a88b0aa92e4, 0x163df6fb75d21fee, 0xcbd06d084388b6c2),
    (17, 3000, 2, 0x774b024c08732345, 0xb9ffb3410421ea94, 0x88cc42d50ef19c95),
    (18, 3000, 3, 0x739dd3daabbbcbfd, 0xee05cbefef5cab5e, 0x64fa71b1506376a5),
    (19, 5000, 0, 0x9e53dc548d12a3a0, 0x39ef2cc6acafdad9, 0x94b71308e4f3466b),
    (20, 5000, 1, 0xf6571d0ccb22a177, 0x074690974027f906, 0x756be389657aac63),
    (21, 20000, 0, 0x1a25cf3abbd34d93, 0xe8ba6d27b2b3b379, 0xcaa37594b13360e1),
    (22, 20000, 1, 0x1c73193f5edb91eb, 0xf0888cc8a01a9345, 0x83bf67f86a4c23e9),
    (23, 20000, 4, 0xa6f9a1ee2bd1cff1, 0xabbc4824467c1df3, 0xcbe4efc6ce506531),
    (24, 20000, 3, 0xc549aa0bbada8b66, 0x48295e0fb8932831, 0xc108089479d57a93),
];

#[test]
fn binary_and_4_wide_trees_are_the_recorded_ones() {
    let print = std::env::var_os("GOLDEN_PRINT").is_some();
    let mut wrong = Vec::new();
    for (&(seed, n, style), &(rs, rn, rst, bin, tree, compact)) in
        golden::CASES.iter().zip(&RECORDED)
    {
        assert_eq!(
            (seed, n, style),
            (rs, rn, rst),
            "cases and records out of step"
        );
        let lights = golden::scene(seed, n, style);
        let (b, t, c) = golden::hashes(&lights);
        if print {
            println!("    ({seed}, {n}, {style}, 0x{b:016x}, 0x{t:016x}, 0x{c:016x}),");
        }
        if (b, t, c) != (bin, tree, compact) {
            let same = |x: u64, y: u64| if x == y { "same" } else { "differs" };
            wrong.push(format!(
                "seed {seed}, {n} lights, style {style}: binary {}, 4-wide {}, compact {}",
                same(b, bin),
                same(t, tree),
                same(c, compact)
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
