//! Not part of the API: what the crate's tests, the fuzz checks, the instruments and the SPTD fit
//! reach inside the crate (the quantisation codes, the byte format's sealing, the SPTD tables,
//! the MIS weights, brute-force oracles), with the cargo feature `internals`. Nothing here has
//! a stability promise: names, signatures and behaviour change without notice.
//!
//! The submodules are named for the crate's modules whose items they re-export.

/// Bounding volumes of lights and clusters.
pub mod bounds {
    pub use crate::bounds::{Aabb, Cone, LightBounds, Sphere};
}

/// Helpers of the BRDFs.
pub mod brdf {
    pub use crate::brdf::schlick;
}

/// The byte format's checksums.
pub mod checksum {
    pub use crate::checksum::crc64;
}

/// Limits of the light sampling routines.
pub mod light_point {
    pub use crate::light::point::MIN_SPHERICAL_SOLID_ANGLE;
}

/// Multiple importance sampling: budgets and weights.
pub mod mis {
    pub use crate::mis::{
        balance, brdf_budget, power, sample_budget, technique_pdfs, AdaptiveAllocator,
        CombinedWeights, Factors, Mixture, SequentialWeights, TechniquePdfs, N_MAX,
    };
}

/// The quantisation codes of the nodes.
pub mod quantize {
    pub use crate::quantize::{encode_cone, encode_energy, encode_spheres};
}

/// Constants of the descents.
pub mod sample {
    pub use crate::sample::{BATCH_LANES, ONE_MINUS_EPSILON};
}

/// Ray queries.
pub mod trace {
    pub use crate::trace::trace_all;
}

/// The BRDF-oriented importance's constants.
pub mod bl {
    pub use crate::importance::bl::{DEFENSIVE, MAX_IMPORTANCE};
}

/// The SPTD of the GGX lobe: tables, fits and cap integrals.
pub mod sptd {
    pub use crate::importance::sptd::*;
}

/// The tree's byte format and node fields.
pub mod tree {
    use crate::bounds::{Cone, Sphere};
    use crate::tree::Node4;
    use bytemuck::{Pod, Zeroable};

    pub use crate::tree::bytes::{seal, HEADER_BYTES};

    /// A [`Node4`] with its fields readable and writable: the same bytes
    /// ([`Node4Ext::raw`], [`Node4Ext::raw_mut`], `From` both ways).
    #[repr(C, align(64))]
    #[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
    pub struct RawNode4 {
        /// Sphere codes, one word per slot.
        pub sphere: [u32; 4],
        /// Cone codes, one word per slot.
        pub cone: [u32; 4],
        /// Origin of the sphere codes.
        pub origin: [f32; 3],
        /// Index of the first inner child node.
        pub child_base: u32,
        /// Slot energies: the upper 16 bits of their 20-bit codes.
        pub energy: [u16; 4],
        /// Index of the first light slot in the leaf array.
        pub leaf_base: u32,
        /// Slot energies: the low 4 bits of their codes, slot k in bits 4k..4k+4.
        pub energy_low: u16,
        /// Scale exponent of the sphere codes (biased by 127).
        pub exponent: u8,
        /// Inner-node slots in bits 0–3, light slots in bits 4–7.
        pub mask: u8,
    }

    impl From<Node4> for RawNode4 {
        fn from(node: Node4) -> RawNode4 {
            bytemuck::cast(node)
        }
    }

    impl From<RawNode4> for Node4 {
        fn from(raw: RawNode4) -> Node4 {
            bytemuck::cast(raw)
        }
    }

    /// What tests read and write of a [`Node4`] beyond its API.
    pub trait Node4Ext {
        /// The node's fields.
        fn raw(&self) -> &RawNode4;
        /// The node's fields, writable.
        fn raw_mut(&mut self) -> &mut RawNode4;
        /// Slot `k`'s sphere, decoded.
        fn sphere(&self, k: usize) -> Sphere;
        /// Slot `k`'s cone, decoded.
        fn cone(&self, k: usize) -> Cone;
        /// Sets slot `k`'s 20-bit energy code.
        fn set_energy_code(&mut self, k: usize, code: u32);
    }

    impl Node4Ext for Node4 {
        fn raw(&self) -> &RawNode4 {
            bytemuck::cast_ref(self)
        }
        fn raw_mut(&mut self) -> &mut RawNode4 {
            bytemuck::cast_mut(self)
        }
        fn sphere(&self, k: usize) -> Sphere {
            Node4::sphere(self, k)
        }
        fn cone(&self, k: usize) -> Cone {
            Node4::cone(self, k)
        }
        fn set_energy_code(&mut self, k: usize, code: u32) {
            Node4::set_energy_code(self, k, code);
        }
    }
}

/// What tests read of a [`Light`](crate::Light) beyond its API.
pub mod light {
    use crate::bounds::LightBounds;
    use crate::light::Light;

    /// A light's bounds.
    pub trait LightExt {
        /// The light's bounds: box, sphere, emission cone and energy.
        fn bounds(&self) -> LightBounds;
    }

    impl LightExt for Light {
        fn bounds(&self) -> LightBounds {
            Light::bounds(self)
        }
    }
}
