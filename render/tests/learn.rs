//! Renders learning visibility (`--learn`, [`Learn`]): the same bits on one thread and on
//! two (the cache's state changes only at the commits between passes, from integer sums),
//! the passes' sample counts, and an image average that agrees with the render without
//! learning within a tolerance from the sample count.

use manylights::Technique;
use manylights_render::render::{render, Learn, Protocol, RenderConfig};
use manylights_render::scene;

fn cfg(technique: Technique, spp: usize, learn: Option<Learn>) -> RenderConfig {
    RenderConfig {
        width: 24,
        height: 18,
        spp,
        technique,
        seed: 7,
        progress: false,
        protocol: Protocol::Jittered,
        params: Default::default(),
        learn,
    }
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

#[test]
fn passes_double_and_add_up() {
    assert_eq!(Learn::passes(1), vec![1]);
    assert_eq!(Learn::passes(2), vec![1, 1]);
    assert_eq!(Learn::passes(8), vec![1, 1, 2, 4]);
    assert_eq!(Learn::passes(10), vec![1, 1, 2, 4, 2]);
    for spp in 1..100 {
        assert_eq!(Learn::passes(spp).iter().sum::<usize>(), spp);
    }
}

/// One thread and two give the same image, bit for bit, for every technique given the
/// cache (and the image differs from the one without learning: the cache was used).
#[test]
fn learning_renders_the_same_bits_on_any_number_of_threads() {
    let scene = scene::by_name("city", None).unwrap();
    for t in [Technique::Bl, Technique::BlMis, Technique::Full] {
        let c = cfg(t, 8, Some(Learn::default()));
        let one = pool(1).install(|| render(&scene, &c));
        let two = pool(2).install(|| render(&scene, &c));
        let bits = |img: &manylights_render::image::Image| {
            img.mean
                .iter()
                .flat_map(|p| p.map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&one), bits(&two), "{t}");
        assert_eq!(one.failed, 0);
        let plain = pool(2).install(|| render(&scene, &cfg(t, 8, None)));
        assert_ne!(bits(&one), bits(&plain), "{t}: learning changed nothing");
    }
}

/// The learned render's image average agrees with the plain one's within 6 standard errors
/// of their difference (from the per-pixel sample variances).
#[test]
fn learning_keeps_the_image_average() {
    let scene = scene::by_name("city", None).unwrap();
    let a = render(&scene, &cfg(Technique::BlMis, 64, Some(Learn::default())));
    let b = render(&scene, &cfg(Technique::BlMis, 64, None));
    let n = a.mean.len() as f64;
    let stats = |img: &manylights_render::image::Image| {
        let m: f64 = img.mean.iter().map(|p| f64::from(p[0])).sum::<f64>() / n;
        // The average's variance: Σ var_pixel / spp / n².
        let v: f64 =
            img.var.iter().map(|p| f64::from(p[0])).sum::<f64>() / img.spp as f64 / (n * n);
        (m, v)
    };
    let ((ma, va), (mb, vb)) = (stats(&a), stats(&b));
    let se = (va + vb).sqrt();
    assert!((ma - mb).abs() <= 6.0 * se, "{ma} vs {mb} (se {se})");
}
