//! The visibility cache family (`ml_visibility_cache_*`, `ml_estimator_set_visibility_cache`,
//! `ml_estimator_record`): caches created for a tree from options, committed, cleared,
//! recording turned on and off, their statistics and sizes, given to estimators (whose
//! set-ups, estimates and step loops then use and feed them) and freed, before or after the
//! estimators that use them.

use super::Harness;
use crate::ffi::buffers::{In, Out};
use crate::ffi::grammar::{CacheCall, Op, Ptr, F};
use manylights_ffi::*;

/// A live cache: its handle, its table's counters (cells × slots) and its cells.
pub(super) struct Cache {
    pub(super) p: *mut ml_visibility_cache,
    counters: u64,
    cells: u64,
}

impl Harness<'_> {
    /// A cache operation: `CacheCreate` to `Record`.
    pub(super) fn cache_op(&mut self, op: &Op) {
        match op {
            Op::CacheCreate { tree, options, out } => {
                let (t, _, th) = self.tree(*tree);
                let v = &options.value;
                let mut d = Out::<ml_visibility_cache_options>::one(Ptr::Valid);
                let s = ml_visibility_cache_options_default(v.cell_size.value(), d.p());
                if !self.status("ml_visibility_cache_options_default", s, &[&d]) {
                    return;
                }
                let mut o = d.get(0);
                o.cells = v.cells.value(ML_MAX_VISIBILITY_CELLS);
                o.slots = v.slots.value(ML_MAX_VISIBILITY_SLOTS);
                o.floor = v.floor.map_or(o.floor, F::value);
                let opts = In::one(o, options.ptr);
                let mut out = Out::<*mut ml_visibility_cache>::one(*out);
                let s = ml_visibility_cache_create(t, opts.p(), out.p());
                if self.status("ml_visibility_cache_create", s, &[&th, &opts, &out]) {
                    let p = out.get(0);
                    self.ensure(!p.is_null(), || "ml_visibility_cache_create: NULL".into());
                    let ok = o.cell_size > 0.0
                        && o.cell_size.is_finite()
                        && o.cells.is_power_of_two()
                        && o.cells <= ML_MAX_VISIBILITY_CELLS
                        && o.slots.is_power_of_two()
                        && o.slots <= ML_MAX_VISIBILITY_SLOTS
                        && o.floor > 0.0
                        && o.floor <= 1.0
                        && u64::from(o.cells) * u64::from(o.slots) <= ML_MAX_VISIBILITY_COUNTERS;
                    self.ensure(ok, || format!("ml_visibility_cache_create accepted {o:?}"));
                    self.caches.push(Cache {
                        p,
                        counters: u64::from(o.cells) * u64::from(o.slots),
                        cells: u64::from(o.cells),
                    });
                }
            }
            Op::CacheFree(h) => {
                let (i, p, ch) = self.cache(*h);
                let s = ml_visibility_cache_free(p);
                if self.status("ml_visibility_cache_free", s, &[&ch]) {
                    if let Some(i) = i {
                        self.caches.swap_remove(i);
                    }
                }
            }
            Op::Cache { cache, call } => {
                let (i, c, ch) = self.cache(*cache);
                match *call {
                    CacheCall::Commit => {
                        let s = ml_visibility_cache_commit(c);
                        self.status("ml_visibility_cache_commit", s, &[&ch]);
                    }
                    CacheCall::Clear => {
                        let s = ml_visibility_cache_clear(c);
                        self.status("ml_visibility_cache_clear", s, &[&ch]);
                    }
                    CacheCall::SetRecording(on) => {
                        let s = ml_visibility_cache_set_recording(c, u32::from(on));
                        if self.status("ml_visibility_cache_set_recording", s, &[&ch]) {
                            self.ensure(on <= 1, || format!("recording set to {on}"));
                        }
                    }
                    CacheCall::Stats(out) => {
                        let mut o = Out::<ml_visibility_cache_counts>::one(out);
                        let s = ml_visibility_cache_stats(c, o.p());
                        if self.status("ml_visibility_cache_stats", s, &[&ch, &o]) {
                            let st = o.get(0);
                            let counters = i.map_or(u64::MAX, |i| self.caches[i].counters);
                            self.ensure(
                                st.visible <= st.samples
                                    && st.used <= st.samples
                                    && st.used <= counters,
                                || format!("ml_visibility_cache_stats: {st:?}"),
                            );
                        }
                    }
                    CacheCall::Bytes(out) => {
                        let mut o = Out::<usize>::one(out);
                        let s = ml_visibility_cache_bytes(c, o.p());
                        if self.status("ml_visibility_cache_bytes", s, &[&ch, &o]) {
                            let b = o.get(0) as u64;
                            if let Some(i) = i {
                                // 17 bytes per counter and a flag per cell.
                                let want = self.caches[i].counters * 17 + self.caches[i].cells;
                                self.ensure(b == want, || {
                                    format!("ml_visibility_cache_bytes: {b}, not {want}")
                                });
                            }
                        }
                    }
                }
            }
            Op::SetCache { est, cache } => {
                let (_, e, eh) = self.est(*est);
                let (_, c, ch) = self.cache(*cache);
                let s = ml_estimator_set_visibility_cache(e, c);
                self.status("ml_estimator_set_visibility_cache", s, &[&eh, &ch]);
            }
            Op::Record { est, visible } => {
                let (_, e, eh) = self.est(*est);
                let s = ml_estimator_record(e, u32::from(*visible));
                if self.status("ml_estimator_record", s, &[&eh]) {
                    self.ensure(*visible <= 1, || format!("recorded visible = {visible}"));
                }
            }
            _ => unreachable!("{op:?} is no visibility cache operation"),
        }
    }
}
