//! Learned visibility: a cache, made for one tree's lights, that counts per cell of space and
//! normal direction how many shadow rays towards each cluster of the BRDF-oriented cut were
//! blocked, and scales the cut's cluster weights by what it learned (the core's
//! `VisibilityCache`). Estimators are given it with `ml_estimator_set_visibility_cache`.

use crate::arg;
use crate::error::{ml_status, Error, Result};
use crate::ffi_fn;
use crate::tree::{ml_tree, tree_arg, TreeData};
use manylights::direct::visibility::{
    MAX_VISIBILITY_CELLS, MAX_VISIBILITY_COUNTERS, MAX_VISIBILITY_SLOTS,
};
use manylights::direct::{VisibilityCache, VisibilityError, VisibilityField, VisibilityOptions};
use std::sync::Arc;

/// The most cells of a visibility cache (`ml_visibility_cache_options.cells`).
pub const ML_MAX_VISIBILITY_CELLS: u32 = 1_048_576;
const _: () = assert!(ML_MAX_VISIBILITY_CELLS == MAX_VISIBILITY_CELLS);

/// The most counters per cell of a visibility cache (`ml_visibility_cache_options.slots`).
pub const ML_MAX_VISIBILITY_SLOTS: u32 = 4096;
const _: () = assert!(ML_MAX_VISIBILITY_SLOTS == MAX_VISIBILITY_SLOTS);

/// The most counters of a visibility cache (`cells · slots`): 2^24.
pub const ML_MAX_VISIBILITY_COUNTERS: u64 = 16_777_216;
const _: () = assert!(ML_MAX_VISIBILITY_COUNTERS == MAX_VISIBILITY_COUNTERS);

/// Options of `ml_visibility_cache_create` (`ml_visibility_cache_options_default` fills the
/// defaults for a cell size). The cache takes `cells · (slots · 17 + 1)` bytes (17 MiB with the
/// defaults; `cells · slots` at most `ML_MAX_VISIBILITY_COUNTERS`), allocated once at
/// creation.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ml_visibility_cache_options {
    /// The side of a grid cell in the scene's units (finite, > 0): points closer than this
    /// tend to share what they learned; a few hundredths of the scene's extent is usual.
    pub cell_size: f32,
    /// Cells of the table: a power of two in [1, `ML_MAX_VISIBILITY_CELLS`] (default 4096);
    /// grid cells beyond it share blocks.
    pub cells: u32,
    /// Counters per cell: a power of two in [1, `ML_MAX_VISIBILITY_SLOTS`] (default 256); a
    /// few times the cut's size keeps clusters from sharing one.
    pub slots: u32,
    /// The smallest factor a cluster's weight is multiplied by, in (0, 1] (default 0.1; 1
    /// learns nothing): where the cache is wrong a cluster's probability falls by at most
    /// 1 / floor, and no light that could be sampled without the cache gets pmf 0.
    pub floor: f32,
}

/// What a cache's committed state holds (`ml_visibility_cache_stats`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ml_visibility_cache_counts {
    /// Counters (cell, slot) with at least one sample.
    pub used: u64,
    /// Light samples counted.
    pub samples: u64,
    /// Of which visible.
    pub visible: u64,
}

/// The cache and the tree it was made for, shared by its handle and the estimators given it.
pub(crate) struct CacheData {
    pub(crate) cache: VisibilityCache,
    pub(crate) tree: Arc<TreeData>,
}

/// A visibility cache (opaque), made for one tree's lights by `ml_visibility_cache_create`.
/// Shared: every thread's estimators may use one cache at once, and every function taking
/// it may be called from any thread at any time (records are atomic integer additions).
/// What sampling reads changes only at `ml_visibility_cache_commit` and
/// `ml_visibility_cache_clear`: for the same bits with fixed seeds on any number of threads,
/// call them between passes, when no estimate runs, and set estimators up again after them.
/// It keeps its tree alive, and estimators keep it alive: the handle may be freed while they
/// use it.
pub struct ml_visibility_cache {
    pub(crate) data: Arc<CacheData>,
}

/// The cache behind a handle.
#[inline]
pub(crate) fn cache_arg<'a>(
    cache: *const ml_visibility_cache,
    name: &str,
) -> Result<&'a Arc<CacheData>> {
    Ok(&arg::get(cache, name)?.data)
}

/// A core options error in the C argument's terms.
fn options_error(e: VisibilityError, o: &ml_visibility_cache_options) -> Error {
    let (field, need, got) = match e.field {
        VisibilityField::CellSize => ("cell_size", "finite and positive", o.cell_size.to_string()),
        VisibilityField::Cells => (
            "cells",
            "a power of two in [1, ML_MAX_VISIBILITY_CELLS] = [1, 1048576]",
            o.cells.to_string(),
        ),
        VisibilityField::Slots => (
            "slots",
            "a power of two in [1, ML_MAX_VISIBILITY_SLOTS] = [1, 4096]",
            o.slots.to_string(),
        ),
        VisibilityField::Floor => ("floor", "in (0, 1]", o.floor.to_string()),
        _ => return Error::invalid(format_args!("options: {e}")),
    };
    Error::invalid(format_args!("options.{field} must be {need} (got {got})"))
}

/// Fills `*out` with the default options (4096 cells, 256 slots, floor 0.1) and `cell_size`
/// (checked by `ml_visibility_cache_create`).
///
/// Errors: `ML_ERR_NULL` if `out` is NULL.
#[no_mangle]
pub extern "C" fn ml_visibility_cache_options_default(
    cell_size: f32,
    out: *mut ml_visibility_cache_options,
) -> ml_status {
    ffi_fn!("ml_visibility_cache_options_default", {
        let o = VisibilityOptions::with_cell_size(cell_size);
        arg::out(out, "out")?.write(ml_visibility_cache_options {
            cell_size: o.cell_size,
            cells: o.cells,
            slots: o.slots,
            floor: o.floor,
        });
        Ok(())
    })
}

/// Creates a visibility cache for the lights of `tree` (built by `ml_tree_build` or loaded by
/// `ml_tree_load_with_lights`) with nothing learned (every factor 1: estimators sample as
/// without it) and recording on. Give it to estimators of this tree with
/// `ml_estimator_set_visibility_cache`; free it with `ml_visibility_cache_free`.
///
/// Errors: `ML_ERR_NULL` (`tree`, `options`, `out`); `ML_ERR_INVALID_ARGUMENT` (a field of
/// `options` out of its range, named: `options.cell_size`, `options.cells`, `options.slots`,
/// `options.floor`); `ML_ERR_STATE` (a tree loaded by `ml_tree_load`, without its lights).
#[no_mangle]
pub extern "C" fn ml_visibility_cache_create(
    tree: *const ml_tree,
    options: *const ml_visibility_cache_options,
    out: *mut *mut ml_visibility_cache,
) -> ml_status {
    ffi_fn!("ml_visibility_cache_create", {
        let data = tree_arg(tree)?;
        let o = arg::get(options, "options")?;
        let out = arg::out(out, "out")?;
        let set = data.set()?;
        let opts = VisibilityOptions {
            cell_size: o.cell_size,
            cells: o.cells,
            slots: o.slots,
            floor: o.floor,
        };
        let cache = VisibilityCache::new(set, opts).map_err(|e| options_error(e, o))?;
        out.write(arg::into_handle(ml_visibility_cache {
            data: Arc::new(CacheData {
                cache,
                tree: Arc::clone(data),
            }),
        }));
        Ok(())
    })
}

/// Frees a cache handle (NULL: nothing). Estimators given the cache keep it until they are
/// freed or given another.
#[no_mangle]
pub extern "C" fn ml_visibility_cache_free(cache: *mut ml_visibility_cache) -> ml_status {
    ffi_fn!("ml_visibility_cache_free", {
        arg::free_handle(cache, "cache")
    })
}

/// Adds the records made since the last commit into the counts sampling reads, and clears
/// them: estimators set up after it (`ml_estimator_set_point`) sample with what was learned.
/// Safe from any thread at any time; for determinism, between passes (see
/// `ml_visibility_cache`).
///
/// Errors: `ML_ERR_NULL` (`cache`).
#[no_mangle]
pub extern "C" fn ml_visibility_cache_commit(cache: *mut ml_visibility_cache) -> ml_status {
    ffi_fn!("ml_visibility_cache_commit", {
        cache_arg(cache, "cache")?.cache.commit();
        Ok(())
    })
}

/// Forgets everything learned and pending (every factor 1 again). As
/// `ml_visibility_cache_commit`, between passes.
///
/// Errors: `ML_ERR_NULL` (`cache`).
#[no_mangle]
pub extern "C" fn ml_visibility_cache_clear(cache: *mut ml_visibility_cache) -> ml_status {
    ffi_fn!("ml_visibility_cache_clear", {
        cache_arg(cache, "cache")?.cache.clear();
        Ok(())
    })
}

/// Turns recording on (`on` = 1, as made) or off (0): off, estimators record nothing (a final
/// pass that no commit follows need not pay for it) and sample with what was committed.
///
/// Errors: `ML_ERR_NULL` (`cache`); `ML_ERR_INVALID_ARGUMENT` (`on` other than 0 or 1).
#[no_mangle]
pub extern "C" fn ml_visibility_cache_set_recording(
    cache: *mut ml_visibility_cache,
    on: u32,
) -> ml_status {
    ffi_fn!("ml_visibility_cache_set_recording", {
        let c = cache_arg(cache, "cache")?;
        if on > 1 {
            return Err(Error::invalid(format_args!("on must be 0 or 1 (got {on})")));
        }
        c.cache.set_recording(on == 1);
        Ok(())
    })
}

/// Writes what the committed state holds (the counters with data, the samples and visible
/// samples counted; a walk over the whole table, for reports) to `*out`.
///
/// Errors: `ML_ERR_NULL` (`cache`, `out`).
#[no_mangle]
pub extern "C" fn ml_visibility_cache_stats(
    cache: *const ml_visibility_cache,
    out: *mut ml_visibility_cache_counts,
) -> ml_status {
    ffi_fn!("ml_visibility_cache_stats", {
        let c = cache_arg(cache, "cache")?;
        let out = arg::out(out, "out")?;
        let s = c.cache.stats();
        out.write(ml_visibility_cache_counts {
            used: s.used,
            samples: s.samples,
            visible: s.visible,
        });
        Ok(())
    })
}

/// Writes the bytes the cache's tables take (`cells · (slots · 17 + 1)`) to `*out`.
///
/// Errors: `ML_ERR_NULL` (`cache`, `out`).
#[no_mangle]
pub extern "C" fn ml_visibility_cache_bytes(
    cache: *const ml_visibility_cache,
    out: *mut usize,
) -> ml_status {
    ffi_fn!("ml_visibility_cache_bytes", {
        let c = cache_arg(cache, "cache")?;
        arg::out(out, "out")?.write(c.cache.bytes());
        Ok(())
    })
}
