//! Sampling a built cut and its pmfs: one light of the whole cut (the root choice between the
//! node tree's clusters and the lights at infinity, then a cluster and a light in it), one
//! light per cluster, and the exact pmf of any light, per cluster and over the cut.

use super::{Cluster, LightCut, CUT_CAPACITY, CUT_LANES};
use crate::importance::Importance;
use crate::sample::{
    root_product, sanitize, SampledLight, Start, WalkStart, MIN_PMF, ONE_MINUS_EPSILON,
};
use crate::tree::{path_len, LightTree, Slot};
use core::cell::Cell;

impl LightCut {
    /// Samples a light in cluster `i` with `u`: its pmf is relative to the cluster (the
    /// split-sampling estimator divides cluster i's contribution by it). `None` if `i` is out of
    /// range or no light of the cluster can contribute.
    pub fn sample_in<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        i: usize,
        u: f32,
    ) -> Option<SampledLight> {
        let c = self.clusters().get(i)?;
        tree.sample_cluster(imp, c, u)
    }

    /// One light in each cluster: `out[i]` gets exactly what `sample_in(tree, imp, i, u[i])`
    /// returns, for `i < min(len, u.len(), out.len())` (what split sampling needs).
    ///
    /// Faster than calling [`LightCut::sample_in`] for each cluster: the descents run four at
    /// a time, interleaved, so their dependent steps overlap.
    ///
    /// ```
    /// use manylights::cut::CUT_CAPACITY;
    /// use manylights::importance::MemoTable;
    /// use manylights::{Light, LightCut, LightTree, Memo, SplitCutOptions, TlImportance};
    /// use glam::Vec3;
    ///
    /// let lights: Vec<Light> = (0..200)
    ///     .map(|i| Light::Point {
    ///         position: Vec3::new((i % 20) as f32, (i / 20) as f32, 2.0),
    ///         intensity: 1.0.into(),
    ///     })
    ///     .collect();
    /// let tree = LightTree::build(&lights)?;
    /// let at = TlImportance::new(Vec3::new(3.0, 4.0, 0.0), Vec3::Z);
    /// let cut = LightCut::build_split(&tree, &at, &SplitCutOptions::default());
    /// // Many samples at this point: let the importance remember the nodes it evaluated (in a
    /// // table kept per thread and reused at every point).
    /// let table = MemoTable::new();
    /// let memo = Memo::new(at, &tree, &table);
    /// let (u, mut out) = ([0.5; CUT_CAPACITY], [None; CUT_CAPACITY]);
    /// cut.sample_each(&tree, &memo, &u[..cut.len()], &mut out[..cut.len()]);
    /// for (i, s) in out[..cut.len()].iter().enumerate() {
    ///     assert_eq!(*s, cut.sample_in(&tree, &at, i, 0.5));
    /// }
    /// # Ok::<(), manylights::BuildError>(())
    /// ```
    pub fn sample_each<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        u: &[f32],
        out: &mut [Option<SampledLight>],
    ) {
        let n = self.len().min(u.len()).min(out.len());
        tree.descend_many::<&I, CUT_LANES>(
            n,
            |_| &imp,
            |i| match tree.slot_of(&self.clusters[i]) {
                Slot::Light(light) => Err(Some(SampledLight { light, pmf: 1.0 })),
                Slot::Node(child) => Ok(Start {
                    node: child,
                    root: false,
                    u: u[i],
                    floor: MIN_PMF,
                }),
                Slot::Empty => Err(None),
            },
            |i, s| out[i] = s,
        );
    }

    /// [`LightCut::pmf_in`] for many lights: `out[i]` gets exactly `pmf_in(tree, imp,
    /// lights[i])`, for `i < min(lights.len(), out.len())`. The walks run four at a time,
    /// interleaved (as in [`LightCut::sample_each`]).
    pub fn pmf_in_each<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        lights: &[u32],
        out: &mut [Option<(usize, f32)>],
    ) {
        self.walk_each(tree, imp, lights, out, false);
    }

    /// The walks of [`LightCut::pmf_in_each`] (`whole` false) or of [`LightCut::pmf_each`]
    /// (`whole` true: the pmf within the cluster as [`LightCut::sample`] reports it, `None` for
    /// lights of clusters it never chooses).
    fn walk_each<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        lights: &[u32],
        out: &mut [Option<(usize, f32)>],
        whole: bool,
    ) {
        let n = lights.len().min(out.len());
        for o in out[..n].iter_mut() {
            *o = None;
        }
        // `start_of` records the cluster of each light; `emit` adds the pmf within it.
        let cluster: [Cell<usize>; CUT_CAPACITY] = core::array::from_fn(|_| Cell::new(usize::MAX));
        let mut done = 0;
        while done < n {
            let m = (n - done).min(CUT_CAPACITY);
            let ls = &lights[done..done + m];
            let os = &mut out[done..done + m];
            tree.pmf_many::<&I, CUT_LANES>(
                m,
                |_| &imp,
                |i| {
                    let light = ls[i];
                    cluster[i].set(usize::MAX);
                    let found = self.cluster_of(tree, light).and_then(|(ci, c, path)| {
                        if whole {
                            Some((ci, c, path, self.sample_share(ci)?.1))
                        } else {
                            Some((ci, c, path, MIN_PMF))
                        }
                    });
                    let Some((ci, c, path, floor)) = found else {
                        return Err(f32::NAN);
                    };
                    cluster[i].set(ci);
                    // A cluster that is a node takes the walk; otherwise the single-light
                    // answer of `pmf_cluster`.
                    match tree.slot_of(c) {
                        Slot::Node(child) => Ok(WalkStart {
                            node: child,
                            root: false,
                            path,
                            from_level: path_len(c.path),
                            light,
                            floor,
                        }),
                        _ => Err(tree.pmf_cluster(imp, c, path, light, floor)),
                    }
                },
                |i, p| {
                    if cluster[i].get() != usize::MAX {
                        os[i] = Some((cluster[i].get(), p));
                    }
                },
            );
            done += m;
        }
    }

    /// [`LightCut::pmf`] for many lights: `out[i]` gets exactly `pmf(tree, imp, lights[i])`,
    /// for `i < min(lights.len(), out.len())`, the walks interleaved as in
    /// [`LightCut::pmf_in_each`].
    pub fn pmf_each<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        lights: &[u32],
        out: &mut [f32],
    ) {
        if self.root.is_some() {
            for (o, &l) in out.iter_mut().zip(lights) {
                *o = self.pmf(tree, imp, l);
            }
            return;
        }
        let mut within = [None; CUT_CAPACITY];
        for (ls, os) in lights
            .chunks(CUT_CAPACITY)
            .zip(out.chunks_mut(CUT_CAPACITY))
        {
            let m = ls.len().min(os.len());
            self.walk_each(tree, imp, &ls[..m], &mut within[..m], true);
            for j in 0..m {
                os[j] = match within[j].and_then(|(ci, p)| Some((self.sample_share(ci)?.0, p))) {
                    Some((q, p)) => q * p,
                    None => 0.0,
                };
            }
        }
    }

    /// The cluster of the cut on `light`'s path, its index, and the light's path.
    ///
    /// A cluster's path is a prefix of the light's exactly when shifting the light's path right
    /// by the difference of their leading zeros gives the cluster's. The clusters are disjoint,
    /// so at most one matches; the scan has no data-dependent branch.
    fn cluster_of(&self, tree: &LightTree, light: u32) -> Option<(usize, &Cluster, u64)> {
        let path = tree.path(light);
        if path == 0 {
            // Not in the node tree: a light at infinity, a cluster of its own, or none.
            let entry = tree.infinite_entry(light)?;
            let i = self.len
                + self.clusters[self.len..self.len + self.infinite]
                    .iter()
                    .position(|c| usize::from(c.slot) == entry)?;
            return Some((i, &self.clusters[i], 0));
        }
        let lz = path.leading_zeros();
        let mut found = usize::MAX;
        for (i, c) in self.tree_clusters().iter().enumerate() {
            let shift = c.path.leading_zeros().wrapping_sub(lz);
            let hit = c.path != 0 && shift < 64 && path >> (shift & 63) == c.path;
            found = if hit { i } else { found };
        }
        self.clusters.get(found).map(|c| (found, c, path))
    }

    /// The cluster of the cut holding `light` (the node tree's cluster on its path, or its
    /// own cluster for a light at infinity); `None` where no cluster holds it.
    #[must_use]
    pub fn cluster_holding(&self, tree: &LightTree, light: u32) -> Option<&Cluster> {
        self.cluster_of(tree, light).map(|(_, c, _)| c)
    }

    /// The cluster holding `light` and the light's pmf within it (what
    /// [`LightCut::sample_in`] reports for it); `None` if no cluster of the cut holds it.
    pub fn pmf_in<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        light: u32,
    ) -> Option<(usize, f32)> {
        let (i, c, path) = self.cluster_of(tree, light)?;
        Some((i, tree.pmf_cluster(imp, c, path, light, MIN_PMF)))
    }

    /// Samples one light of the whole cut: a cluster with probability weight / total, then a
    /// light in it. The pmf is the product (at least [`MIN_PMF`]: clusters and lights whose
    /// share would be smaller are never chosen; see the module documentation).
    ///
    /// With lights at infinity, the choice is first made at the root
    /// ([`LightCut::root_choice`]): between the node tree's clusters, of weight the sum of
    /// their weights, and each light at infinity, of its weight (its cluster's), as the
    /// estimators' [`crate::direct::CutSampler`] chooses (`u` rescaled into the chosen
    /// interval). A light at infinity then has the pmf of its choice; a light of the node
    /// tree has that of the node tree times what the cut's clusters give it, and a product
    /// below [`MIN_PMF`] counts as no light (`None`, and [`LightCut::pmf`] 0).
    pub fn sample<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        u: f32,
    ) -> Option<SampledLight> {
        let Some(root) = &self.root else {
            return self.sample_tree(tree, imp, u);
        };
        let (k, p, rest) = root.pick(u)?;
        if k > 0 {
            let light = tree.infinite.get(k - 1)?.light;
            return Some(SampledLight { light, pmf: p });
        }
        let s = self.sample_tree(tree, imp, rest)?;
        let pmf = root_product(p, s.pmf);
        (pmf > 0.0).then_some(SampledLight {
            light: s.light,
            pmf,
        })
    }

    /// [`LightCut::sample`] among the node tree's clusters alone.
    fn sample_tree<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        u: f32,
    ) -> Option<SampledLight> {
        if self.len == 0 {
            return None;
        }
        let total = self.sample_total;
        let t = sanitize(u) * total;
        // The first cluster whose running sum passes t (one that is left out repeats the sum
        // before it, so it is never the first), else the last that can be chosen: the
        // clusters' weights in [0, total) laid end to end in their order.
        let ends = &self.ends[..self.len];
        let i = ends.partition_point(|&e| e <= t).min(self.last);
        let w = self.sample_weight(i)?;
        let before = if i == 0 { 0.0 } else { ends[i - 1] };
        let u2 = ((t - before) / w).clamp(0.0, ONE_MINUS_EPSILON);
        let (q, floor) = self.sample_share(i)?;
        let s = tree.sample_cluster_from(imp, &self.clusters[i], u2, floor)?;
        Some(SampledLight {
            light: s.light,
            pmf: q * s.pmf,
        })
    }

    /// The probability that [`LightCut::sample`] returns `light`: exactly the pmf it reports.
    pub fn pmf<I: Importance + ?Sized>(&self, tree: &LightTree, imp: &I, light: u32) -> f32 {
        let Some(root) = &self.root else {
            return self.pmf_tree(tree, imp, light);
        };
        if let Some(i) = tree.infinite_entry(light) {
            return root.probability(1 + i);
        }
        let p = root.probability(0);
        if p <= 0.0 {
            return 0.0;
        }
        root_product(p, self.pmf_tree(tree, imp, light))
    }

    /// [`LightCut::pmf`] among the node tree's clusters alone (0 for a light at infinity).
    fn pmf_tree<I: Importance + ?Sized>(&self, tree: &LightTree, imp: &I, light: u32) -> f32 {
        let Some((i, c, path)) = self.cluster_of(tree, light) else {
            return 0.0;
        };
        match self.sample_share(i) {
            Some((q, floor)) => q * tree.pmf_cluster(imp, c, path, light, floor),
            None => 0.0,
        }
    }
}

impl LightTree {
    /// What `cluster`'s slot holds ([`Slot::Empty`] for a cluster naming no node of this tree).
    #[inline]
    fn slot_of(&self, cluster: &Cluster) -> Slot {
        if let Some(entry) = cluster.infinite_entry() {
            return self
                .infinite
                .get(entry)
                .map_or(Slot::Empty, |e| Slot::Light(e.light));
        }
        self.nodes
            .get(cluster.node as usize)
            .map_or(Slot::Empty, |n| self.slot(n, usize::from(cluster.slot) & 3))
    }

    /// Samples a light under `cluster` (pmf relative to it, at least [`MIN_PMF`]).
    pub fn sample_cluster<I: Importance + ?Sized>(
        &self,
        imp: &I,
        cluster: &Cluster,
        u: f32,
    ) -> Option<SampledLight> {
        self.sample_cluster_from(imp, cluster, u, MIN_PMF)
    }

    /// [`LightTree::sample_cluster`] with lights of pmf below `floor` (in [`MIN_PMF`, 1]) left
    /// out.
    fn sample_cluster_from<I: Importance + ?Sized>(
        &self,
        imp: &I,
        cluster: &Cluster,
        u: f32,
        floor: f32,
    ) -> Option<SampledLight> {
        match self.slot_of(cluster) {
            Slot::Light(light) => Some(SampledLight { light, pmf: 1.0 }),
            // Below the cluster's slot, whose weight was positive: a node whose four children
            // all have importance 0 falls back to its energies, so a non-empty cut always
            // returns a light and its pmfs sum to 1.
            Slot::Node(c) => self.descend_from(imp, c as usize, false, u, floor),
            Slot::Empty => None,
        }
    }

    /// The pmf of `light` (path `path`) under `cluster`, as
    /// [`LightTree::sample_cluster_from`] reports it with the same `floor`; the caller has
    /// checked the path goes through the cluster.
    fn pmf_cluster<I: Importance + ?Sized>(
        &self,
        imp: &I,
        cluster: &Cluster,
        path: u64,
        light: u32,
        floor: f32,
    ) -> f32 {
        match self.slot_of(cluster) {
            Slot::Light(l) if l == light => 1.0,
            Slot::Node(c) => self.pmf_from(
                imp,
                &WalkStart {
                    node: c,
                    root: false,
                    path,
                    from_level: path_len(cluster.path),
                    light,
                    floor,
                },
            ),
            _ => 0.0,
        }
    }
}
