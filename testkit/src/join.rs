//! The build's fork-join on rayon's thread pool, for tests and tools (the feature `rayon`).

/// [`manylights::Join`] on rayon's thread pool: the two closures through `rayon::join`, on
/// the pool the call runs in. The tree is the one the serial build makes.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayonJoin;

impl manylights::Join for RayonJoin {
    #[inline]
    fn join<A, B, RA, RB>(&self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA + Send,
        B: FnOnce() -> RB + Send,
        RA: Send,
        RB: Send,
    {
        rayon::join(a, b)
    }
}

#[cfg(test)]
mod tests {
    use super::RayonJoin;
    use manylights::{BuildOptions, LightTree};

    #[test]
    fn a_parallel_build_is_the_serial_build() {
        let lights = crate::lights(20_000, 5);
        let opts = BuildOptions::default();
        let serial = LightTree::build_with(&lights, &opts).unwrap();
        let parallel = LightTree::build_parallel(&lights, &opts, &RayonJoin).unwrap();
        assert_eq!(parallel, serial);
    }
}
