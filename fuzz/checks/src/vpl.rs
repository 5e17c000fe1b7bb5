//! Probabilistic VPL acceptance (Georgiev & Slusallek 2010, section 3) on arbitrary
//! acceptors, importons and candidates, fields raw or in range:
//!
//! - every constructor, setter and push is an error exactly when one of its fields is bad,
//!   naming the first bad one in the order the core checks them (the importons count the pushes
//!   that succeeded, misses included);
//! - for a valid candidate, `estimate` is ≥ 0 (never NaN), `probability` p is in (0, 1] and at
//!   least min(ε, 1), `probability_with` an always-visible test equals it bit for bit and with
//!   any other test is in (0, p];
//! - `accept` and `accept_with` check ξ first: a kept candidate has exactly the probability p
//!   (with ξ ≤ p; `None` means ξ > p), its position and normal, and the intensity `I/p`,
//!   finite, and is a valid light (`Light::validate`: its energy within `MAX_LIGHT_ENERGY`);
//!   the decision counts (`AcceptStats`) add up and stay finite.

use arbitrary::Arbitrary;
use glam::Vec3;
use manylights::error::VplField;
use manylights::vpl::Accepted;
use manylights::Rgb;
use manylights::{Material, Vpl, VplAcceptor, MAX_COORDINATE, MAX_LIGHT_ENERGY};

use crate::bounded::{Dir, Real};

/// The target's input.
#[derive(Arbitrary, Debug)]
pub struct Input {
    /// P (0 is an error).
    pub pixels: u32,
    /// N (0 is an error).
    pub wanted: u32,
    /// ε, when set.
    pub epsilon: Option<Real>,
    /// The geometry clamp, when set.
    pub geometry_clamp: Option<Real>,
    /// Φ̃_total set or refined, in order (the first 8).
    pub luminance: Vec<Luminance>,
    /// The importons (the first 64).
    pub importons: Vec<RawImporton>,
    /// The candidates (the first 32).
    pub candidates: Vec<Candidate>,
    /// Which importons the host's visibility test reports occluded, cycled (empty: none).
    pub occluded: Vec<bool>,
}

/// An f64 amount: as given, or `10^(k/10)`.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Amount {
    /// As given.
    Raw(f64),
    /// `10^(k/10)`.
    Pow10(i8),
}

impl Amount {
    /// The amount.
    pub fn value(self) -> f64 {
        match self {
            Amount::Raw(x) => x,
            Amount::Pow10(k) => 10f64.powf(f64::from(k) / 10.0),
        }
    }
}

/// An update of Φ̃_total.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Luminance {
    /// `set_total_luminance`.
    Set(Amount),
    /// `update` with one frame's luminance.
    Update(Amount),
}

/// A position: as given, or on a grid of 1/16 within ±8.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Position {
    /// As given.
    Raw([f32; 3]),
    /// `k/16` per coordinate.
    Grid([i8; 3]),
}

impl Position {
    /// The point.
    pub fn point(self) -> Vec3 {
        match self {
            Position::Raw(a) => Vec3::from_array(a),
            Position::Grid(k) => Vec3::from_array(k.map(|k| f32::from(k) / 16.0)),
        }
    }
}

/// A material of an importon, fields as drawn.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum RawMaterial {
    /// Lambert (albedo).
    Lambert(Real),
    /// GGX (α, specular).
    Ggx(Real, Real),
    /// Plastic (albedo, specular, α).
    Plastic(Real, Real, Real),
}

impl RawMaterial {
    /// The material.
    pub fn material(self) -> Material {
        match self {
            RawMaterial::Lambert(a) => Material::Lambert {
                albedo: Rgb::grey(a.value()),
            },
            RawMaterial::Ggx(alpha, s) => Material::Ggx {
                alpha: alpha.value(),
                specular: s.value(),
            },
            RawMaterial::Plastic(a, s, alpha) => Material::Plastic {
                albedo: Rgb::grey(a.value()),
                specular: s.value(),
                alpha: alpha.value(),
            },
        }
    }
}

/// An importon.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum RawImporton {
    /// `push_diffuse(position, normal, albedo)`.
    Diffuse(Position, Dir, Real),
    /// `push(position, normal, wo, material)`.
    Material(Position, Dir, Dir, RawMaterial),
    /// `push_miss()`.
    Miss,
}

/// A candidate and the uniform number ξ that decides it.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Candidate {
    /// Position.
    pub position: Position,
    /// Normal.
    pub normal: Dir,
    /// Intensity: as given, or `10^(k/10)`.
    pub intensity: Amount,
    /// ξ.
    pub xi: Real,
}

impl Candidate {
    /// The VPL.
    pub fn vpl(&self) -> Vpl {
        Vpl {
            position: self.position.point(),
            normal: self.normal.vector(),
            intensity: Rgb::grey(self.intensity.value() as f32),
        }
    }
}

fn bad_position(p: Vec3) -> bool {
    p.to_array()
        .iter()
        .any(|c| !c.is_finite() || c.abs() > MAX_COORDINATE)
}

fn bad_direction(v: Vec3) -> bool {
    !v.is_finite() || v == Vec3::ZERO
}

fn bad_unit(x: f32) -> bool {
    !(0.0..=1.0).contains(&x)
}

fn bad_luminance(x: f64) -> bool {
    !(x.is_finite() && x >= 0.0)
}

/// The field a candidate's check must name, or `None` for a valid candidate.
pub fn candidate_error(v: &Vpl) -> Option<VplField> {
    if bad_position(v.position) {
        Some(VplField::Position)
    } else if bad_direction(v.normal) {
        Some(VplField::Normal)
    } else if !(v
        .intensity
        .to_array()
        .iter()
        .all(|c| c.is_finite() && *c >= 0.0)
        && core::f64::consts::PI * f64::from(v.intensity.luminance())
            <= f64::from(MAX_LIGHT_ENERGY))
    {
        Some(VplField::Intensity)
    } else {
        None
    }
}

/// The field pushing an importon must name, or `None` for a valid importon.
pub fn importon_error(i: &RawImporton) -> Option<VplField> {
    match *i {
        RawImporton::Diffuse(p, n, albedo) => {
            if bad_position(p.point()) {
                Some(VplField::ImportonPosition)
            } else if bad_direction(n.vector()) {
                Some(VplField::ImportonNormal)
            } else if bad_unit(albedo.value()) {
                Some(VplField::ImportonMaterial)
            } else {
                None
            }
        }
        RawImporton::Material(p, n, wo, m) => {
            let (albedo, specular, alpha) = m.material().lobes();
            if bad_position(p.point()) {
                Some(VplField::ImportonPosition)
            } else if bad_direction(n.vector()) {
                Some(VplField::ImportonNormal)
            } else if bad_direction(wo.vector()) {
                Some(VplField::ImportonWo)
            } else if bad_unit(albedo) || bad_unit(specular) || !(alpha > 0.0 && alpha <= 1.0) {
                Some(VplField::ImportonMaterial)
            } else {
                None
            }
        }
        RawImporton::Miss => None,
    }
}

/// `Ok` exactly when `want` is `None`, else an error naming `want`.
fn expect<T: core::fmt::Debug>(
    what: &str,
    got: Result<T, manylights::VplError>,
    want: Option<VplField>,
    input: &Input,
) -> Option<T> {
    match (got, want) {
        (Ok(v), None) => Some(v),
        (Err(e), Some(field)) => {
            assert_eq!(e.field, field, "{what}: {e}: {input:?}");
            assert!(e.to_string().contains(field.name()), "{what}: {e}");
            None
        }
        (got, want) => panic!("{what}: {got:?}, expected an error in {want:?}: {input:?}"),
    }
}

/// Checks a kept candidate against its probability and ξ.
fn kept(what: &str, c: &Vpl, p: f32, xi: f32, got: Option<Accepted>, input: &Input) {
    match got {
        Some(a) => {
            assert_eq!(
                a.probability.to_bits(),
                p.to_bits(),
                "{what}: {a:?}: {input:?}"
            );
            assert!(xi <= p, "{what}: kept with ξ = {xi} > p = {p}: {input:?}");
            assert_eq!(a.vpl.position, c.position, "{what}: {input:?}");
            assert_eq!(a.vpl.normal, c.normal, "{what}: {input:?}");
            assert_eq!(
                a.vpl.intensity.to_array().map(f32::to_bits),
                (c.intensity / p).to_array().map(f32::to_bits),
                "{what}: {a:?}: {input:?}"
            );
            assert!(
                a.vpl.intensity.is_finite(),
                "{what}: the scaled intensity of {c:?} is {:?} (p = {p}): {input:?}",
                a.vpl.intensity
            );
            if let Err(e) = a.vpl.light().validate(0) {
                panic!("{what}: the kept VPL {a:?} is no valid light ({e}): {input:?}");
            }
        }
        None => assert!(
            xi > p,
            "{what}: rejected with ξ = {xi} ≤ p = {p}: {input:?}"
        ),
    }
}

/// Checks the properties of the module's documentation.
pub fn check(input: &Input) {
    let (pixels, wanted) = (input.pixels as usize, input.wanted as usize);
    let want = if pixels == 0 {
        Some(VplField::Pixels)
    } else if wanted == 0 {
        Some(VplField::Wanted)
    } else {
        None
    };
    let Some(mut acc) = expect("new", VplAcceptor::new(pixels, wanted), want, input) else {
        return;
    };
    if let Some(e) = input.epsilon {
        let e = e.value();
        let want = (!(e.is_finite() && e > 0.0)).then_some(VplField::Epsilon);
        if let Some(a) = expect("with_epsilon", acc.clone().with_epsilon(e), want, input) {
            assert_eq!(a.epsilon().to_bits(), e.to_bits());
            acc = a;
        }
    }
    if let Some(g) = input.geometry_clamp {
        let g = g.value();
        let want = (g.is_nan() || g <= 0.0).then_some(VplField::GeometryClamp);
        if let Some(a) = expect(
            "with_geometry_clamp",
            acc.clone().with_geometry_clamp(g),
            want,
            input,
        ) {
            acc = a;
        }
    }
    for l in input.luminance.iter().take(8) {
        let (what, x, got) = match *l {
            Luminance::Set(x) => (
                "set_total_luminance",
                x.value(),
                acc.set_total_luminance(x.value()),
            ),
            Luminance::Update(x) => ("update", x.value(), acc.update(x.value())),
        };
        expect(
            what,
            got,
            bad_luminance(x).then_some(VplField::Luminance),
            input,
        );
        let t = acc.total_luminance();
        assert!(t.is_finite() && t >= 0.0, "Φ̃_total = {t}: {input:?}");
    }
    let mut count = 0;
    for i in input.importons.iter().take(64) {
        let imp = acc.importons_mut();
        let got = match *i {
            RawImporton::Diffuse(p, n, albedo) => {
                imp.push_diffuse(p.point(), n.vector(), albedo.value())
            }
            RawImporton::Material(p, n, wo, m) => {
                imp.push(p.point(), n.vector(), wo.vector(), m.material())
            }
            RawImporton::Miss => {
                imp.push_miss();
                Ok(())
            }
        };
        if expect("push", got, importon_error(i), input).is_some() {
            count += 1;
        }
    }
    assert_eq!(acc.importons().len(), count, "importons: {input:?}");

    // The host's visibility test: a function of the importon's position, so that every call
    // with the same candidate sees the same occluders.
    let pattern = &input.occluded;
    let mut occlusion = |x: Vec3, _: Vec3| {
        let h = x.x.to_bits() ^ x.y.to_bits().rotate_left(11) ^ x.z.to_bits().rotate_left(22);
        pattern.is_empty() || !pattern[h as usize % pattern.len()]
    };
    let mut visible = |_: Vec3, _: Vec3| true;
    let epsilon = acc.epsilon();
    let (mut decided, mut accepted) = (0u64, 0u64);
    for cand in input.candidates.iter().take(32) {
        let c = cand.vpl();
        let want = candidate_error(&c);
        let xi = cand.xi.value();
        let xi_error = (!(0.0..1.0).contains(&xi)).then_some(VplField::Xi);
        let p = expect("estimate", acc.estimate(&c), want, input).map(|phi| {
            assert!(phi >= 0.0, "Φ̃_i = {phi} for {c:?}: {input:?}");
            let p = acc.probability(&c).expect("a valid candidate");
            assert!(p > 0.0 && p <= 1.0, "p = {p} for {c:?}: {input:?}");
            assert!(
                p >= epsilon.min(1.0),
                "p = {p} < ε = {epsilon} for {c:?}: {input:?}"
            );
            let pv = acc
                .probability_with(&c, &mut visible)
                .expect("a valid candidate");
            assert_eq!(
                pv.to_bits(),
                p.to_bits(),
                "probability_with, all visible: {input:?}"
            );
            let po = acc
                .probability_with(&c, &mut occlusion)
                .expect("a valid candidate");
            assert!(
                po > 0.0 && po <= p,
                "p = {po} with occlusion, {p} without: {input:?}"
            );
            (p, po)
        });
        if want.is_some() {
            expect("probability", acc.probability(&c), want, input);
            expect(
                "probability_with",
                acc.probability_with(&c, &mut visible),
                want,
                input,
            );
        }
        let decisions = [
            ("accept", acc.accept(&c, xi), p.map(|p| p.0)),
            (
                "accept_with",
                acc.accept_with(&c, xi, &mut occlusion),
                p.map(|p| p.1),
            ),
        ];
        for (what, got, p) in decisions {
            if let Some(a) = expect(what, got, xi_error.or(want), input) {
                decided += 1;
                accepted += u64::from(a.is_some());
                kept(what, &c, p.expect("a valid candidate"), xi, a, input);
            }
        }
    }
    let s = acc.stats();
    assert_eq!(
        (s.candidates, s.accepted),
        (decided, accepted),
        "{s:?}: {input:?}"
    );
    let rate = s.acceptance_rate();
    assert!((0.0..=1.0).contains(&rate), "{s:?}: {input:?}");
    if s.candidates > 0 {
        let m = s.mean_probability();
        assert!(m > 0.0 && m <= 1.0, "{s:?}: {input:?}");
    }
    for (what, x) in [
        ("sum_probability", s.sum_probability),
        ("candidate_energy", s.candidate_energy),
        ("accepted_energy", s.accepted_energy),
        ("energy_variance", s.energy_variance),
    ] {
        assert!(x.is_finite() && x >= 0.0, "{what} = {x}: {s:?}: {input:?}");
    }
}

impl crate::Checked for Input {
    fn check(&self) {
        check(self)
    }
}
