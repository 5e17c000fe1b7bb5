//! The build's choices, pinned: for seeded scenes of every light kind and layout, the hash of
//! the binary SAOH tree (each node's bounds, energy and child, as the baseline stores them)
//! and of the 4-wide tree's paths (which binary clusters became the slots of which node)
//! equal the ones recorded with the build of commit 7760e2d, before the build's memory
//! layout and speed work. A change to a split, a bound or a slot shows here; one that is
//! meant must record new hashes (run with `GOLDEN_PRINT=1` and `--nocapture`).

mod golden;

/// (seed, lights, style, binary tree, paths).
const RECORDED: [(u64, usize, u32, u64, u64); 24] = [
    (1, 1, 0, 0xb122d32dfb68399c, 0x2cdcdc0dfc5d1141),
    (2, 2, 0, 0xde098cc63362214b, 0xa9181db43578e1c4),
    (3, 3, 1, 0x8f1e07c63048e43a, 0xa592129392ea6e82),
    (4, 4, 0, 0xcd3c0b928ae3a0c6, 0x4b5960710f070a85),
    (5, 5, 4, 0xec238fdacbe6fa3a, 0x44a23284930ae0c1),
    (6, 6, 2, 0x88226e288a4f1d23, 0x722b9fc6886b49e6),
    (7, 9, 3, 0x561fc35e1399c573, 0x253f56f0d79a8255),
    (8, 17, 0, 0xad5980bae3f7c678, 0xc31a2fa406654615),
    (9, 33, 1, 0x312b44605d5d8a8f, 0xc837423344d1a940),
    (10, 100, 0, 0xce28469c8b9a305a, 0x2a7d9e51da49cfb3),
    (11, 100, 4, 0xf8cf481fdd286fdf, 0x4ccfc8f955e6c9b3),
    (12, 300, 2, 0x04212d44d0daf686, 0x6b3bdef43aad9ccc),
    (13, 300, 3, 0x6b2a002ff88af45f, 0xd3001f3348663b1a),
    (14, 1000, 0, 0x068ca093a51d25fa, 0xa8f8e4657c3bfc78),
    (15, 1000, 1, 0x96b3d01cabc076cc, 0x6b37173f053303f4),
    (16, 1000, 4, 0x26871a88b0aa92e4, 0xe06bd71bfa08de98),
    (17, 3000, 2, 0x774b024c08732345, 0xa71ebd0d291a485b),
    (18, 3000, 3, 0x739dd3daabbbcbfd, 0xaa3f80c3172e5781),
    (19, 5000, 0, 0x9e53dc548d12a3a0, 0x67cab61f5ad1522e),
    (20, 5000, 1, 0xf6571d0ccb22a177, 0x4ff0f7fed7e106a7),
    (21, 20000, 0, 0x1a25cf3abbd34d93, 0x0be47e5b64af09b7),
    (22, 20000, 1, 0x1c73193f5edb91eb, 0xda537e866ea04ef8),
    (23, 20000, 4, 0xa6f9a1ee2bd1cff1, 0xd67c6090ede00018),
    (24, 20000, 3, 0xc549aa0bbada8b66, 0x8b160ae263d0efde),
];

#[test]
fn binary_tree_and_slots_are_the_recorded_ones() {
    let print = std::env::var_os("GOLDEN_PRINT").is_some();
    let mut wrong = Vec::new();
    for (&(seed, n, style), &(rs, rn, rst, bin, paths)) in golden::CASES.iter().zip(&RECORDED) {
        assert_eq!(
            (seed, n, style),
            (rs, rn, rst),
            "cases and records out of step"
        );
        let lights = golden::scene(seed, n, style);
        let (b, p) = golden::hashes(&lights);
        if print {
            println!("    ({seed}, {n}, {style}, 0x{b:016x}, 0x{p:016x}),");
        }
        if (b, p) != (bin, paths) {
            wrong.push(format!(
                "seed {seed}, {n} lights, style {style}: binary {}, paths {}",
                if b == bin { "same" } else { "differs" },
                if p == paths { "same" } else { "differs" }
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
