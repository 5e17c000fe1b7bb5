//! Visibility learned while rendering: a cache that counts, per cell of space and normal
//! direction, how many of the shadow rays towards each group of lights were blocked, and
//! scales the BRDF-oriented cut's cluster weights by what it learned.
//!
//! # What is learned
//!
//! A *cell* is a block of a fixed-size table, chosen by the shading point's position (a grid
//! of side `cell_size`, hashed) and the dominant axis of its normal (six directions). Each
//! cell has `slots` counters, and a cluster of a cut (a slot of the tree, by its path, or a
//! light at infinity) is counted in the slot its hash picks (clusters whose hashes meet share
//! it). For each (cell, slot) the cache keeps two integers: `n`, the light samples drawn from
//! the cluster at points of the cell that the host tested with a shadow ray, and `v`, how
//! many of them were visible. A sample is drawn in proportion to its light's importance
//! within the cluster, so `v / n` estimates the cluster's visible share of its predicted
//! contribution. Nearby points build nearly the same cut, so the clusters a cut asks about
//! are those its neighbours' samples were counted in.
//!
//! # How it is used
//!
//! An [`Estimator`](crate::Estimator) given a cache
//! ([`Estimator::with_visibility`](crate::Estimator::with_visibility)) multiplies each
//! cluster's weight in its BRDF-oriented cut (the cut of `bl`, `bl-mis`, `mis-equal` and
//! `full`) by
//!
//! ```text
//! factor = floor + (1 − floor) · v̂,   v̂ = min(1, (v + 1) / (n + 1))
//! ```
//!
//! (`v̂` rounded to 255ths at the commit: a set-up reads one byte per cluster, a cell's in a
//! few cache lines). With no data `v̂ = 1` and the cut is the one without a cache. The factor is a
//! function of the cache's *committed* state only, and the cut's sampling and pmf queries both
//! use the scaled weights, so the pmf of every light stays exact (sampled = queried, bit for
//! bit) and the estimators stay unbiased whatever the cache learned; a factor is at least
//! `floor`, so no light that could be chosen without the cache becomes impossible, and where
//! the cache is wrong a cluster's probability falls by at most `1 / floor`.
//!
//! # Determinism and threads
//!
//! Records go to *pending* counters by relaxed atomic integer additions through `&self`, so
//! every thread records into the one cache with no per-thread recorder to merge; the
//! committed counts, which sampling reads, change only at [`VisibilityCache::commit`] (and
//! [`VisibilityCache::clear`]), which adds the pending counts into them. Integer sums do not
//! depend on the order of the additions, so a render that commits between passes gives the
//! same bits with fixed seeds on any number of threads. A pending counter that receives 2³²
//! records between two commits wraps; the estimate stays unbiased (only the importance
//! suffers). Every operation is safe from any thread at any time; only the determinism asks
//! the host to commit between passes.
//!
//! # Memory
//!
//! `cells × (slots × 17 + 1)` bytes (8 committed, 8 pending and the share in 255ths per slot,
//! and a flag per cell; 4.25 KiB per cell with the default 256 slots, 17 MiB with the default
//! 4096 cells), allocated once by
//! [`VisibilityCache::new`]; nothing in the per-sample path allocates.
//! [`VisibilityCache::bytes`] reports it.

use crate::cut::Cluster;
use crate::light_set::LightSet;
use crate::tree::LightTree;
use alloc::vec::Vec;
use core::fmt;
use core::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicU8, Ordering};
use glam::Vec3;

/// The most slots a cell can have.
pub const MAX_VISIBILITY_SLOTS: u32 = 1 << 12;

/// The most cells a cache can have.
pub const MAX_VISIBILITY_CELLS: u32 = 1 << 20;

/// The most counters (cells × slots) a cache can have: 2²⁴, 272 MiB of tables.
pub const MAX_VISIBILITY_COUNTERS: u64 = 1 << 24;

/// How a [`VisibilityCache`] partitions space and how far it may lower a cluster's weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VisibilityOptions {
    /// The side of a grid cell, in the scene's units (finite, > 0). Points closer than this
    /// tend to share what they learned; a few hundredths of the scene's extent is usual.
    pub cell_size: f32,
    /// The number of cells of the table (a power of two, 1..=[`MAX_VISIBILITY_CELLS`], with
    /// `cells × slots` ≤ [`MAX_VISIBILITY_COUNTERS`]): grid cells beyond it share blocks.
    pub cells: u32,
    /// The counters per cell (a power of two, 1..=[`MAX_VISIBILITY_SLOTS`]); a few times the
    /// cut's size keeps clusters from sharing one.
    pub slots: u32,
    /// The smallest factor a cluster's weight is multiplied by (in (0, 1]; 1 learns nothing).
    pub floor: f32,
}

impl VisibilityOptions {
    /// The default cells, slots and floor ([`VisibilityOptions::DEFAULT_CELLS`],
    /// [`VisibilityOptions::DEFAULT_SLOTS`], [`VisibilityOptions::DEFAULT_FLOOR`]) with the
    /// given cell size.
    #[must_use]
    pub const fn with_cell_size(cell_size: f32) -> VisibilityOptions {
        VisibilityOptions {
            cell_size,
            cells: VisibilityOptions::DEFAULT_CELLS,
            slots: VisibilityOptions::DEFAULT_SLOTS,
            floor: VisibilityOptions::DEFAULT_FLOOR,
        }
    }

    /// The default number of cells.
    pub const DEFAULT_CELLS: u32 = 4096;
    /// The default number of slots per cell.
    pub const DEFAULT_SLOTS: u32 = 256;
    /// The default floor.
    pub const DEFAULT_FLOOR: f32 = 0.1;
}

/// A field of [`VisibilityOptions`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum VisibilityField {
    /// `cell_size`.
    CellSize,
    /// `cells`.
    Cells,
    /// `slots`.
    Slots,
    /// `floor`.
    Floor,
}

impl VisibilityField {
    /// The field's name, as in [`VisibilityOptions`] (and the C `ml_visibility_cache_options`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            VisibilityField::CellSize => "cell_size",
            VisibilityField::Cells => "cells",
            VisibilityField::Slots => "slots",
            VisibilityField::Floor => "floor",
        }
    }
}

/// A [`VisibilityOptions`] field out of its range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VisibilityError {
    /// The field.
    pub field: VisibilityField,
    /// Its value.
    pub value: f64,
}

impl fmt::Display for VisibilityError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let need = match self.field {
            VisibilityField::CellSize => "finite and positive",
            VisibilityField::Cells => {
                "a power of two in 1..=1048576, with cells × slots ≤ 16777216"
            }
            VisibilityField::Slots => "a power of two in 1..=4096",
            VisibilityField::Floor => "in (0, 1]",
        };
        write!(
            f,
            "visibility options: {} must be {need} (got {})",
            self.field.name(),
            self.value
        )
    }
}

impl core::error::Error for VisibilityError {}

/// What a [`VisibilityCache`]'s committed state holds ([`VisibilityCache::stats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VisibilityStats {
    /// Counters (cell, slot) with at least one sample.
    pub used: u64,
    /// Samples counted.
    pub samples: u64,
    /// Of which visible.
    pub visible: u64,
}

/// The committed counts of one (cell, slot): samples tested and samples visible.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Counts {
    n: u32,
    v: u32,
}

/// The learned visibility of a light set's clusters, per cell of space (see the
/// [module documentation](self)). Made for one light set; given to estimators by reference;
/// recorded into by every thread at once; committed by the host between passes.
pub struct VisibilityCache {
    options: VisibilityOptions,
    /// What identifies the light set the cache was made for: its light count, its tree's
    /// depth and its lights at infinity's count.
    made_for: (u32, u32, u32),
    /// Two per (cell, slot): n, then v. Written only by [`VisibilityCache::commit`] and
    /// [`VisibilityCache::clear`].
    committed: Vec<AtomicU32>,
    /// Two per (cell, slot): n, then v.
    pending: Vec<AtomicU32>,
    /// One per (cell, slot): the visible share of the committed counts, `(v + 1) / (n + 1)`,
    /// in 255ths (255 with no data): what the set-ups read, a cell's in a few cache lines.
    shares: Vec<AtomicU8>,
    /// One per cell: whether it has pending records (what a commit visits).
    dirty: Vec<AtomicBool>,
    recording: AtomicBool,
    commits: AtomicU64,
}

impl fmt::Debug for VisibilityCache {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("VisibilityCache")
            .field("options", &self.options)
            .field("recording", &self.recording)
            .field("commits", &self.commits)
            .finish_non_exhaustive()
    }
}

/// A 64-bit mix (the finaliser of SplitMix64).
#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl VisibilityCache {
    /// A cache for `set` with nothing learned (every factor 1), recording on.
    ///
    /// Errors: a field of `options` out of its range, named.
    pub fn new(
        set: &LightSet,
        options: VisibilityOptions,
    ) -> Result<VisibilityCache, VisibilityError> {
        let bad = |field, value: f64| Err(VisibilityError { field, value });
        if !(options.cell_size > 0.0 && options.cell_size < f32::INFINITY) {
            return bad(VisibilityField::CellSize, f64::from(options.cell_size));
        }
        if !(options.cells.is_power_of_two() && options.cells <= MAX_VISIBILITY_CELLS) {
            return bad(VisibilityField::Cells, f64::from(options.cells));
        }
        if !(options.slots.is_power_of_two() && options.slots <= MAX_VISIBILITY_SLOTS) {
            return bad(VisibilityField::Slots, f64::from(options.slots));
        }
        if !(options.floor > 0.0 && options.floor <= 1.0) {
            return bad(VisibilityField::Floor, f64::from(options.floor));
        }
        if u64::from(options.cells) * u64::from(options.slots) > MAX_VISIBILITY_COUNTERS {
            return bad(VisibilityField::Cells, f64::from(options.cells));
        }
        let len = options.cells as usize * options.slots as usize;
        let zeros = || {
            let mut v = Vec::with_capacity(2 * len);
            v.resize_with(2 * len, || AtomicU32::new(0));
            v
        };
        Ok(VisibilityCache {
            options,
            made_for: VisibilityCache::identity(set.tree()),
            committed: zeros(),
            pending: zeros(),
            shares: {
                let mut v = Vec::with_capacity(len);
                v.resize_with(len, || AtomicU8::new(255));
                v
            },
            dirty: {
                let mut v = Vec::with_capacity(options.cells as usize);
                v.resize_with(options.cells as usize, || AtomicBool::new(false));
                v
            },
            recording: AtomicBool::new(true),
            commits: AtomicU64::new(0),
        })
    }

    fn identity(tree: &LightTree) -> (u32, u32, u32) {
        (
            tree.light_count(),
            tree.depth(),
            tree.infinite_lights().len() as u32,
        )
    }

    /// Whether the cache was made for a light set of `tree`'s shape (its light count, depth
    /// and lights at infinity).
    #[must_use]
    pub fn fits(&self, tree: &LightTree) -> bool {
        self.made_for == VisibilityCache::identity(tree)
    }

    /// The options it was made with.
    #[must_use]
    pub fn options(&self) -> &VisibilityOptions {
        &self.options
    }

    /// The bytes its tables take (committed and pending counts).
    #[must_use]
    pub fn bytes(&self) -> usize {
        (self.committed.len() + self.pending.len()) * core::mem::size_of::<AtomicU32>()
            + self.shares.len()
            + self.dirty.len()
    }

    /// How many times [`VisibilityCache::commit`] ran.
    #[must_use]
    pub fn commits(&self) -> u64 {
        self.commits.load(Ordering::Relaxed)
    }

    /// Whether records are kept (on when made). Off, [`VisibilityCache::record`] does
    /// nothing: a final pass that will not be followed by a commit need not pay for it.
    #[must_use]
    pub fn recording(&self) -> bool {
        self.recording.load(Ordering::Relaxed)
    }

    /// Turns recording on or off.
    pub fn set_recording(&self, on: bool) {
        self.recording.store(on, Ordering::Relaxed);
    }

    /// The cell of a shading point at `position` with normal `normal` (any length; a zero or
    /// non-finite normal has a cell of its own direction).
    #[must_use]
    pub fn cell(&self, position: Vec3, normal: Vec3) -> u32 {
        let q = position / self.options.cell_size;
        // `as` saturates, and takes NaN to 0: every position has a cell.
        let (x, y, z) = (
            libm::floorf(q.x) as i32,
            libm::floorf(q.y) as i32,
            libm::floorf(q.z) as i32,
        );
        let a = normal.abs();
        let dir = if !(a.x.is_finite() && a.y.is_finite() && a.z.is_finite()) || a == Vec3::ZERO {
            6
        } else if a.x >= a.y && a.x >= a.z {
            u32::from(normal.x < 0.0)
        } else if a.y >= a.z {
            2 + u32::from(normal.y < 0.0)
        } else {
            4 + u32::from(normal.z < 0.0)
        };
        let h = mix(u64::from(x as u32)
            ^ mix(u64::from(y as u32) ^ mix(u64::from(z as u32) ^ (u64::from(dir) << 32))));
        (h as u32) & (self.options.cells - 1)
    }

    /// The index of `cluster`'s counters at `cell` (`cell` below the cache's cells).
    #[inline]
    fn index(&self, cell: u32, cluster: &Cluster) -> usize {
        // A light at infinity: its entry above every path (paths have a marker bit below 64).
        let key = match cluster.infinite_entry() {
            Some(e) => u64::MAX - e as u64,
            None => cluster.path,
        };
        let slot = (mix(key ^ 0x5bd1_e995_9e37_79b9) as u32) & (self.options.slots - 1);
        cell as usize * self.options.slots as usize + slot as usize
    }

    /// Records a shadow ray of a light sample drawn from `cluster` (a cluster of a cut at a
    /// point of `cell`, [`VisibilityCache::cell`]): whether it was visible. Thread-safe;
    /// takes effect at the next [`VisibilityCache::commit`]. Record only samples whose
    /// unshadowed contribution is positive, drawn from the cut by the estimators (other rays
    /// would bias what is learned towards them, though never the estimates).
    #[inline]
    pub fn record(&self, cell: u32, cluster: &Cluster, visible: bool) {
        if !self.recording() || cell >= self.options.cells {
            return;
        }
        let i = 2 * self.index(cell, cluster);
        if let Some(d) = self.dirty.get(cell as usize) {
            if !d.load(Ordering::Relaxed) {
                d.store(true, Ordering::Relaxed);
            }
        }
        if let Some(n) = self.pending.get(i) {
            n.fetch_add(1, Ordering::Relaxed);
        }
        if visible {
            if let Some(v) = self.pending.get(i + 1) {
                v.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// Adds the pending records into the committed counts and clears them: the state the
    /// factors are computed from changes here and in [`VisibilityCache::clear`], nowhere
    /// else. Counts past 2³¹ are halved (both of a pair, so their ratio stays).
    ///
    /// For the same bits on any number of threads, commit between passes, when no estimate
    /// is running and no estimator set up before the commit is used after it (a commit
    /// while threads render is safe, but which of their records and set-ups see it is not
    /// determined).
    pub fn commit(&self) {
        let slots = self.options.slots as usize;
        let cells = self
            .committed
            .chunks_exact(2 * slots)
            .zip(self.pending.chunks_exact(2 * slots))
            .zip(self.shares.chunks_exact(slots))
            .zip(&self.dirty);
        for (((c, p), q), d) in cells {
            if d.swap(false, Ordering::Relaxed) {
                commit_cell(c, p, q);
            }
        }
        self.commits.fetch_add(1, Ordering::Relaxed);
    }
}

/// Adds a cell's pending counts `p` into its committed counts `c` and shares `q`
/// ([`VisibilityCache::commit`]).
fn commit_cell(c: &[AtomicU32], p: &[AtomicU32], q: &[AtomicU8]) {
    {
        for ((c, p), q) in c.chunks_exact(2).zip(p.chunks_exact(2)).zip(q) {
            let pn = p[0].swap(0, Ordering::Relaxed);
            let pv = p[1].swap(0, Ordering::Relaxed);
            if pn == 0 && pv == 0 {
                continue;
            }
            let mut n = u64::from(c[0].load(Ordering::Relaxed)) + u64::from(pn);
            let mut v = (u64::from(c[1].load(Ordering::Relaxed)) + u64::from(pv)).min(n);
            while n >= 1 << 31 {
                n /= 2;
                v /= 2;
            }
            c[0].store(n as u32, Ordering::Relaxed);
            c[1].store(v as u32, Ordering::Relaxed);
            q.store(share_255(n, v), Ordering::Relaxed);
        }
    }
}

impl VisibilityCache {
    /// Forgets everything learned and pending (every factor 1 again); as for
    /// [`VisibilityCache::commit`], between passes.
    pub fn clear(&self) {
        for c in self.committed.iter().chain(&self.pending) {
            c.store(0, Ordering::Relaxed);
        }
        for q in &self.shares {
            q.store(255, Ordering::Relaxed);
        }
    }

    /// The committed counts (samples, visible) of a counter.
    #[inline]
    fn counts(&self, i: usize) -> Counts {
        match (self.committed.get(2 * i), self.committed.get(2 * i + 1)) {
            (Some(n), Some(v)) => Counts {
                n: n.load(Ordering::Relaxed),
                v: v.load(Ordering::Relaxed),
            },
            _ => Counts::default(),
        }
    }

    /// What the committed state holds: the counters with data, and the samples and visible
    /// samples counted (summed over the table; a walk over it, for reports).
    #[must_use]
    pub fn stats(&self) -> VisibilityStats {
        (0..self.committed.len() / 2).fold(VisibilityStats::default(), |s, i| {
            let c = self.counts(i);
            VisibilityStats {
                used: s.used + u64::from(c.n > 0),
                samples: s.samples + u64::from(c.n),
                visible: s.visible + u64::from(c.v),
            }
        })
    }

    /// The factor `cluster`'s weight is multiplied by at `cell` (in [floor, 1]; see the
    /// [module documentation](self)).
    #[must_use]
    pub fn factor(&self, cell: u32, cluster: &Cluster) -> f32 {
        if cell >= self.options.cells {
            return 1.0;
        }
        let q = self
            .shares
            .get(self.index(cell, cluster))
            .map_or(255, |q| q.load(Ordering::Relaxed));
        if q == 255 {
            return 1.0;
        }
        let floor = self.options.floor;
        (floor + (1.0 - floor) * (f32::from(q) / 255.0)).clamp(floor, 1.0)
    }
}

/// `min(1, (v + 1) / (n + 1))` in 255ths, rounded to nearest (`v ≤ n`).
fn share_255(n: u64, v: u64) -> u8 {
    let d = n + 1;
    let q = (255 * (v + 1) + d / 2) / d;
    q.min(255) as u8
}
