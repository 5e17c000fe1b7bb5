//! The batch calls across shading points (`LightTree::sample_batch` and `pmf_batch`, TL and BL
//! importances) and the batched cut queries (`sample_each`, `pmf_in_each`, `pmf_each`) equal
//! the single calls bit for bit on arbitrary bounded inputs. The batch's shading points are the
//! input's point and, with its normal, ωo and material, points next to each light (so the input
//! format, and the committed crash files, stay as they were).

use crate::bounded::{unit, BLight, BPoint};
use arbitrary::Arbitrary;
use manylights::internals::light::LightExt;
use manylights::{
    BlCutOptions, BlImportance, LightCut, LightTree, ShadingPoint, SplitCutOptions, TlImportance,
};

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
    let split = LightCut::build_split(&tree, &tl, &SplitCutOptions::default());
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
    // Across shading points.
    let mut sps = vec![sp];
    for (j, l) in lights.iter().take(40).enumerate() {
        let at = l.bounds().sphere.center + sp.normal * (0.01 * (j % 5) as f32);
        sps.push(ShadingPoint { position: at, ..sp });
    }
    let k = sps.len();
    let us_k: Vec<f32> = (0..k)
        .map(|j| unit(input.us.get(j).copied().unwrap_or(0.7)))
        .collect();
    let ls_k: Vec<u32> = (0..k)
        .map(|j| ls.get(j).copied().unwrap_or(j as u32 % (n + 1)))
        .collect();
    let tls: Vec<TlImportance> = sps
        .iter()
        .map(|p| TlImportance::new(p.position, p.normal))
        .collect();
    let bls: Vec<BlImportance> = sps
        .iter()
        .filter_map(|p| BlImportance::new(p).ok())
        .collect();
    let mut s_out = vec![None; k];
    let mut p_out = vec![0.0f32; k];
    tree.sample_batch(&tls, &us_k, &mut s_out).unwrap();
    tree.pmf_batch(&tls, &ls_k, &mut p_out).unwrap();
    for j in 0..k {
        assert_eq!(
            s_out[j],
            tree.sample(&tls[j], us_k[j]),
            "sample_batch TL, point {j}"
        );
        assert_eq!(
            p_out[j].to_bits(),
            tree.pmf(&tls[j], ls_k[j]).to_bits(),
            "pmf_batch TL, point {j}"
        );
    }
    let kb = bls.len();
    tree.sample_batch(&bls, &us_k[..kb], &mut s_out[..kb])
        .unwrap();
    tree.pmf_batch(&bls, &ls_k[..kb], &mut p_out[..kb]).unwrap();
    for j in 0..kb {
        assert_eq!(
            s_out[j],
            tree.sample(&bls[j], us_k[j]),
            "sample_batch BL, point {j}"
        );
        assert_eq!(
            p_out[j].to_bits(),
            tree.pmf(&bls[j], ls_k[j]).to_bits(),
            "pmf_batch BL, point {j}"
        );
    }
    if let Ok(bl) = BlImportance::new(&sp) {
        let cut = LightCut::build_bl(&tree, &bl, &BlCutOptions::default());
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
