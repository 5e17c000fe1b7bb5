//! Bounded lights of every kind, a shading point, a material and uniform numbers: every light
//! TL, BL and split sampling return has pmf > 0 equal to the queried pmf (1e-5 relative); the
//! pmfs of all lights sum to 1 (1e-4); every `direct` technique's estimate is finite and
//! non-negative.

use crate::bounded::{unit, BLight, BPoint};
use arbitrary::Arbitrary;
use manylights::direct::{Estimator, Params, Technique, Uniforms, Unoccluded};
use manylights::{BlCutOptions, BlImportance, LightCut, LightSet, SplitCutOptions, TlImportance};

/// The target's input.
#[derive(Arbitrary, Debug)]
pub struct Input {
    pub lights: Vec<BLight>,
    pub point: BPoint,
    pub us: Vec<f32>,
}

/// The host's numbers: the fuzzer's, cycled, mapped into [0, 1).
struct Cycle<'a>(&'a [f32], usize);

impl Uniforms for Cycle<'_> {
    fn next_f32(&mut self) -> f32 {
        let u = self
            .0
            .get(self.1 % self.0.len().max(1))
            .copied()
            .unwrap_or(0.5);
        self.1 += 1;
        unit(u + 0.618_034 * self.1 as f32)
    }
    fn next_f64(&mut self) -> f64 {
        f64::from(self.next_f32())
    }
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * a.abs().max(b.abs())
}

fn check_sum(what: &str, n: usize, any: bool, pmf: impl Fn(u32) -> f32) {
    let sum: f64 = (0..n as u32).map(|l| f64::from(pmf(l))).sum();
    if any {
        assert!((sum - 1.0).abs() <= 1e-4, "{what}: pmfs sum to {sum}");
    }
}

/// Checks the properties of the module's documentation.
pub fn check(input: &Input) {
    let lights: Vec<_> = input.lights.iter().take(256).map(BLight::light).collect();
    let Ok(set) = LightSet::build(lights) else {
        return;
    };
    let n = set.len();
    let tree = set.tree();
    let sp = input.point.point();
    let us: Vec<f32> = input.us.iter().take(64).map(|&u| unit(u)).collect();
    let us = if us.is_empty() {
        vec![0.0, 0.5, 0.999]
    } else {
        us
    };

    let tl = TlImportance::new(sp.position, sp.normal);
    let mut any = false;
    for &u in &us {
        if let Some(s) = tree.sample(&tl, u) {
            any = true;
            assert!(s.pmf > 0.0 && s.pmf.is_finite(), "tl: {s:?}");
            assert!(close(s.pmf, tree.pmf(&tl, s.light)), "tl: {s:?}");
        }
    }
    check_sum("tl", n, any, |l| tree.pmf(&tl, l));

    if let Ok(bl) = BlImportance::new(&sp) {
        let cut = LightCut::build_bl(tree, &bl, &BlCutOptions::default());
        let mut any = false;
        for &u in &us {
            if let Some(s) = cut.sample(tree, &bl, u) {
                any = true;
                assert!(s.pmf > 0.0 && s.pmf.is_finite(), "cut: {s:?}");
                assert!(close(s.pmf, cut.pmf(tree, &bl, s.light)), "cut: {s:?}");
            }
        }
        check_sum("cut", n, any, |l| cut.pmf(tree, &bl, l));
    }

    let split = LightCut::build_split(tree, &tl, &SplitCutOptions::default());
    for i in 0..split.len() {
        for &u in &us {
            if let Some(s) = split.sample_in(tree, &tl, i, u) {
                assert!(s.pmf > 0.0 && s.pmf.is_finite(), "split: {s:?}");
                let q = split.pmf_in(tree, &tl, s.light);
                assert!(
                    matches!(q, Some((j, p)) if j == i && close(p, s.pmf)),
                    "split: {s:?} {q:?}"
                );
            }
        }
    }

    for t in Technique::ALL {
        let Ok(mut est) = Estimator::new(&set, &sp, t, &Params::default()) else {
            continue;
        };
        let mut u = Cycle(&us, 0);
        for _ in 0..4 {
            let v = est
                .estimate(&Unoccluded, &mut u)
                .expect("numbers in [0, 1)");
            assert!(v.iter().all(|c| c.is_finite() && *c >= 0.0), "{t}: {v:?}");
        }
    }
}

impl crate::Checked for Input {
    fn check(&self) {
        check(self)
    }
}
