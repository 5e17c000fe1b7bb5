//! The batched cut queries (`sample_each`, `pmf_in_each`, `pmf_each`) equal the single calls
//! bit for bit on arbitrary bounded inputs.

use crate::bounded::{unit, BLight, BPoint};
use arbitrary::Arbitrary;
use manylights::{BlImportance, CutOptions, LightCut, LightTree, SplitOptions, TlImportance};

/// The target's input.
#[derive(Arbitrary, Debug)]
pub struct Input {
    pub lights: Vec<BLight>,
    pub point: BPoint,
    pub us: Vec<f32>,
    pub queries: Vec<u16>,
}

/// Checks the properties of the module's documentation.
pub fn check(input: &Input) {
    let lights: Vec<_> = input.lights.iter().take(256).map(BLight::light).collect();
    let Ok(tree) = LightTree::build(&lights) else {
        return;
    };
    let sp = input.point.point();
    let tl = TlImportance::new(sp.position, sp.normal);
    let split = LightCut::build_split(&tree, &tl, &SplitOptions::default());
    let m = split.len();
    let us: Vec<f32> = (0..m)
        .map(|i| unit(input.us.get(i).copied().unwrap_or(0.3)))
        .collect();
    let mut out = vec![None; m];
    split.sample_each(&tree, &tl, &us, &mut out);
    for i in 0..m {
        assert_eq!(
            out[i],
            split.sample_in(&tree, &tl, i, us[i]),
            "sample_each, cluster {i}"
        );
    }
    let n = lights.len().max(1) as u32;
    let ls: Vec<u32> = input
        .queries
        .iter()
        .take(64)
        .map(|&q| u32::from(q) % (n + 1))
        .collect();
    let mut within = vec![None; ls.len()];
    split.pmf_in_each(&tree, &tl, &ls, &mut within);
    for (k, &l) in ls.iter().enumerate() {
        assert_eq!(
            within[k],
            split.pmf_in(&tree, &tl, l),
            "pmf_in_each, light {l}"
        );
    }
    if let Ok(bl) = BlImportance::new(&sp) {
        let cut = LightCut::build(&tree, &bl, &CutOptions::default());
        let mut p = vec![0.0f32; ls.len()];
        cut.pmf_each(&tree, &bl, &ls, &mut p);
        for (k, &l) in ls.iter().enumerate() {
            assert_eq!(
                p[k].to_bits(),
                cut.pmf(&tree, &bl, l).to_bits(),
                "pmf_each, light {l}"
            );
        }
    }
}

impl crate::Checked for Input {
    fn check(&self) {
        check(self)
    }
}
