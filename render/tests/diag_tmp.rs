use manylights_render::estimator::reference::reference;
use manylights_render::estimator::scene::{Plan, Scene};
use manylights_render::estimator::techniques::{Params, Setup, Technique};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

#[test]
#[ignore]
fn diag() {
    let scene = Scene::new(1000, 1, Plan::Cycle, 1);
    let c = scene.configs[0];
    let r = reference(&scene, &c.sp, 1e-3, 1e-4, 1);
    for t in [Technique::Tl] {
        let setup = Setup::new(&scene, &c.sp, t, &Params::default());
        for seed in [1u64, 2] {
            let mut rng = Pcg64Mcg::seed_from_u64(
                seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
                    .wrapping_add(2 << 8),
            );
            let k = if seed == 1 {
                30_000_000usize
            } else {
                10_000_000
            };
            let (mut s, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..k {
                let x = setup.estimate(t, &mut rng);
                s += x;
                s2 += x * x;
            }
            let n = k as f64;
            let m = s / n;
            let se = ((s2 / n - m * m) / n).sqrt();
            eprintln!(
                "{t:?} seed {seed}: mean {m} exact {} ({} se) z {:.2}",
                r.value,
                r.std_err,
                (m - r.value) / se
            );
        }
    }
}
