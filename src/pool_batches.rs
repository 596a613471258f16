//! How the plugin's per-entity passes split a query across Bevy's compute pool.

use bevy::ecs::batching::BatchingStrategy;

/// Batches of a query on the compute pool are tasks: each costs a spawn, and a thread that
/// is asleep a wake-up, so a batch holds at least this many entities.
const MIN_BATCH: usize = 1024;

/// Batches a thread gets on average: the threads that finish theirs first take the rest.
const BATCHES_PER_THREAD: usize = 4;

/// A batch holds at most this fraction of the pass's entities (but [`MIN_BATCH`]).
const MAX_BATCH_SHARE: usize = 64;

/// The batching of a `par_iter` over `population` entities whose work per entity differs
/// from table to table: the
/// camera's flat culling pass (an entity the trees settle costs a bit read, one they cannot a
/// frustum test) and the parallel sync (a mover costs its world box, a still entity its
/// change tick). The light views' flat pass keeps Bevy's default: these batches measured
/// slower there (docs/experiments.md, Whole frame at several thread counts).
///
/// Why not Bevy's default: it makes one batch per thread, sized by the largest table, so a
/// smaller table is a single batch and goes whole to one thread. Costly entities often have
/// a table of their own (movers carry the game's motion components, cars sit beside the
/// buildings the trees settle), and one thread would then take all of them while the others
/// sit idle (BENCHMARKS.md, Whole frame). Four batches a thread are not enough where the
/// costly table is much smaller than the largest one (a tenth of the world moving: Bevy sizes
/// the batches from the still entities' table, and the movers' table fits in one), so a batch
/// is also capped at a [`MAX_BATCH_SHARE`]th of the population: the costly table then splits
/// by its share of the world, and the tasks stay at most that many plus one per table.
pub(crate) fn uneven_work_batches(population: usize) -> BatchingStrategy {
    BatchingStrategy::new()
        .min_batch_size(MIN_BATCH)
        .max_batch_size((population / MAX_BATCH_SHARE).max(MIN_BATCH))
        .batches_per_thread(BATCHES_PER_THREAD)
}
