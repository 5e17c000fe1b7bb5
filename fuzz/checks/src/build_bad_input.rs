//! Raw, unbounded floats (NaN, ±∞, subnormals, huge) as lights: the build returns an error or a
//! tree that validates; it never panics.

use arbitrary::Arbitrary;
use glam::Vec3;
use manylights::Rgb;
use manylights::{Light, LightTree};

use crate::Checked;

/// A light of any kind from raw floats.
#[derive(Arbitrary, Debug)]
pub enum RawLight {
    Point([f32; 3], f32),
    Spot([f32; 3], [f32; 3], f32, f32, f32),
    Sphere([f32; 3], f32, f32),
    Disk([f32; 3], [f32; 3], f32, f32, bool),
    Triangle([[f32; 3]; 3], f32, bool),
    Vpl([f32; 3], [f32; 3], f32),
}

fn v(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

impl RawLight {
    /// The light, fields as given.
    pub fn light(&self) -> Light {
        match *self {
            RawLight::Point(p, i) => Light::Point {
                position: v(p),
                intensity: Rgb::grey(i),
            },
            RawLight::Spot(p, d, i, h, f) => Light::Spot {
                position: v(p),
                direction: v(d),
                intensity: Rgb::grey(i),
                half_angle: h,
                falloff_start: f,
            },
            RawLight::Sphere(c, r, l) => Light::Sphere {
                center: v(c),
                radius: r,
                radiance: Rgb::grey(l),
            },
            RawLight::Disk(c, n, r, l, two_sided) => Light::Disk {
                center: v(c),
                normal: v(n),
                radius: r,
                radiance: Rgb::grey(l),
                two_sided,
            },
            RawLight::Triangle(t, l, two_sided) => Light::Triangle {
                vertices: [v(t[0]), v(t[1]), v(t[2])],
                radiance: Rgb::grey(l),
                two_sided,
            },
            RawLight::Vpl(p, n, i) => Light::Vpl {
                position: v(p),
                normal: v(n),
                intensity: Rgb::grey(i),
            },
        }
    }
}

/// The target's input: the lights (the first 512 are built).
pub type Input = Vec<RawLight>;

/// The build returns an error or a tree that validates.
pub fn check(raw: &[RawLight]) {
    let lights: Vec<Light> = raw.iter().take(512).map(RawLight::light).collect();
    if let Ok(tree) = LightTree::build(&lights) {
        if let Err(e) = tree.validate() {
            panic!("a built tree does not validate: {e:?}\n{lights:?}");
        }
    }
}

impl Checked for Input {
    fn check(&self) {
        check(self)
    }
}
