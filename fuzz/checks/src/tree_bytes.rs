//! Arbitrary bytes, and mutations of a valid tree's bytes, to `LightTree::from_bytes`: an error
//! or a tree that validates and samples without panicking.

use arbitrary::Arbitrary;
use glam::Vec3;
use manylights::Rgb;
use manylights::{Light, LightTree, TlImportance};

/// The target's input.
#[derive(Arbitrary, Debug)]
pub struct Input {
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
    let bytes = if input.mutate {
        let mut b = valid_tree_bytes();
        let n = b.len();
        for &(at, value) in &input.edits {
            b[at as usize % n] = value;
        }
        b
    } else {
        input.bytes.clone()
    };
    if let Ok(tree) = LightTree::from_bytes(&bytes) {
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
