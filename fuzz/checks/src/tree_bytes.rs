//! Arbitrary bytes, and edits of a valid tree's bytes, to `LightTree::from_bytes`, in two modes:
//!
//! - as they are (`resealed` false): edits of a valid tree's bytes that change them and leave
//!   its checksum field (bytes 16..24) alone are always rejected; anything else is an error or
//!   a tree that validates and samples;
//! - resealed (`resealed` true): the bytes, or the valid tree's payload with the edits, get a
//!   fresh header with their own length and checksum (`manylights::internals::tree::seal`), so that the
//!   structural checks behind the checksum are fuzzed: an error or a tree that validates and
//!   samples, with pmf > 0 equal to the queried one.

use arbitrary::Arbitrary;
use glam::Vec3;
use manylights::internals::tree::{seal, HEADER_BYTES};
use manylights::Rgb;
use manylights::{Light, LightTree, TlImportance};

/// The target's input.
#[derive(Arbitrary, Debug)]
pub struct Input {
    /// The mode: rewrite the header's length and checksum after the edits.
    pub resealed: bool,
    /// Raw bytes, or (with `mutate`) byte edits of a valid tree.
    pub bytes: Vec<u8>,
    pub mutate: bool,
    pub edits: Vec<(u16, u8)>,
    pub u: f32,
}

fn valid_tree_bytes() -> Vec<u8> {
    let lights: Vec<Light> = (0..40)
        .map(|i| {
            let t = i as f32;
            Light::Sphere {
                center: Vec3::new(t.sin() * 5.0, t.cos() * 5.0, 1.0 + (t * 0.37).sin()),
                radius: 0.1 + 0.01 * t,
                radiance: Rgb::grey(1.0 + t),
            }
        })
        .collect();
    LightTree::build(&lights).expect("valid lights").as_bytes()
}

/// Checks the properties of the module's documentation.
pub fn check(input: &Input) {
    let valid = valid_tree_bytes();
    let (bytes, must_reject) = if input.resealed {
        let payload = if input.mutate {
            let mut p = valid[HEADER_BYTES..].to_vec();
            let n = p.len();
            for &(at, value) in &input.edits {
                p[at as usize % n] = value;
            }
            p
        } else {
            input.bytes.clone()
        };
        (seal(&payload), false)
    } else if input.mutate {
        let mut b = valid.clone();
        let n = b.len();
        let mut checksum_edited = false;
        for &(at, value) in &input.edits {
            let i = at as usize % n;
            checksum_edited |= (16..24).contains(&i);
            b[i] = value;
        }
        let changed = b != valid;
        (b, changed && !checksum_edited)
    } else {
        (input.bytes.clone(), false)
    };
    if let Ok(tree) = LightTree::from_bytes(&bytes) {
        assert!(
            !must_reject,
            "edited tree bytes (checksum field untouched) loaded: {input:?}"
        );
        tree.validate()
            .expect("from_bytes returned a tree that does not validate");
        let imp = TlImportance::new(Vec3::ZERO, Vec3::Z);
        if let Some(s) = tree.sample(&imp, input.u) {
            assert!(s.pmf > 0.0 && s.pmf.is_finite(), "{s:?}");
            assert_eq!(s.pmf, tree.pmf(&imp, s.light));
        }
    }
}

impl crate::Checked for Input {
    fn check(&self) {
        check(self)
    }
}
