//! Which lights a ray reaches: [`LightTree::trace`] walks the tree's bounding spheres four
//! slots at a time and intersects the lights whose spheres the ray may reach.
//!
//! Of [`LightTree`]'s API this file holds [`LightTree::trace`] alone; the rest is in
//! [`crate::tree`], [`crate::build`], [`crate::sample`] and [`crate::cut`].
//!
//! BRDF sampling needs this: a direction drawn from the BRDF lands on the lights in front of
//! the first surface, each with its own point and density ([`crate::light::point::intersect`]).
//! Lights do not block each other.

use crate::light::point::{intersect, LightPoint};
use crate::light::Light;
use crate::tree::{LightTree, Node4, Slot, MAX_DEPTH};
use glam::Vec3;
use wide::f32x4;

/// Deepest stack a walk needs: three pending siblings per level plus the four of the last.
const STACK: usize = 3 * MAX_DEPTH as usize + 4;

/// Ray-vs-bounding-sphere tests of a node's four slots at once, conservative against f32
/// rounding of the stored spheres: bit k of the result is set when the ray from `x` along the
/// unit `d` may reach slot k's sphere (empty slots included; the caller skips them).
#[inline(always)]
fn may_hit4(node: &Node4, x: Vec3, d: Vec3) -> u32 {
    let s = node.spheres4();
    let (cx, cy, cz) = (s.x, s.y, s.z);
    let (vx, vy, vz) = (
        cx - f32x4::splat(x.x),
        cy - f32x4::splat(x.y),
        cz - f32x4::splat(x.z),
    );
    let extent = cx.abs().fast_max(cy.abs()).fast_max(cz.abs());
    let r = s.r * f32x4::splat(1.0 + 1e-4) + f32x4::splat(1e-6) * (f32x4::ONE + extent);
    let r2 = r * r;
    let v2 = vx * vx + vy * vy + vz * vz;
    let b = vx * f32x4::splat(d.x) + vy * f32x4::splat(d.y) + vz * f32x4::splat(d.z);
    let (px, py, pz) = (
        vx - f32x4::splat(d.x) * b,
        vy - f32x4::splat(d.y) * b,
        vz - f32x4::splat(d.z) * b,
    );
    let miss2 = px * px + py * py + pz * pz;
    let hit = v2.simd_le(r2) | (b.simd_gt(f32x4::ZERO) & miss2.simd_le(r2));
    hit.to_bitmask()
}

impl LightTree {
    /// Calls `hit(light, point)` for every light of `lights` (the lights this tree was built
    /// from) that the ray from `x` along the unit `d` reaches, with the point it reaches
    /// ([`intersect`]: its distance, radiance and the solid-angle density of sampling it).
    /// Point and spot lights, and lights without energy (which no cluster bounds), are never
    /// reached. Lights do not block each other: a ray through
    /// two lights reports both, in no particular order.
    pub fn trace(&self, lights: &[Light], x: Vec3, d: Vec3, mut hit: impl FnMut(u32, &LightPoint)) {
        let nodes = self.nodes();
        if nodes.is_empty() || !x.is_finite() || !d.is_finite() {
            return;
        }
        let mut stack = [0u32; STACK];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let Some(node) = nodes.get(stack[top] as usize) else {
                continue;
            };
            let mut mask = may_hit4(node, x, d);
            while mask != 0 {
                let k = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                match self.slot(node, k) {
                    Slot::Light(l) => {
                        if let Some(lp) = lights.get(l as usize).and_then(|li| intersect(li, x, d))
                        {
                            hit(l, &lp);
                        }
                    }
                    Slot::Node(c) if top < STACK => {
                        stack[top] = c;
                        top += 1;
                    }
                    _ => {}
                }
            }
        }
    }
}

/// Calls `hit(light, point)` for every light of `lights` that the ray from `x` along the unit
/// `d` reaches, by testing every light: what [`LightTree::trace`] must agree with.
#[cfg(any(test, feature = "internals"))]
pub fn trace_all(lights: &[Light], x: Vec3, d: Vec3, mut hit: impl FnMut(u32, &LightPoint)) {
    for (i, l) in lights.iter().enumerate() {
        if let Some(lp) = intersect(l, x, d) {
            hit(i as u32, &lp);
        }
    }
}
