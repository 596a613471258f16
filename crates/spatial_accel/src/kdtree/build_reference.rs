//! The two slower builds the event sweep is checked against (Wald and Havran 2006, sections
//! 4.1 and 4.2): they price the same planes in the same order with the same arithmetic
//! (`split.rs`), so all three must give the same tree; a difference is a bug in one.

use super::build_events::{Event, push_events, sort_events, sweep};
use super::builder::BuildContext;
use super::split::Part;
use crate::Aabb;

/// O(N^2): every plane where a part's box starts or ends is a candidate, and each one counts
/// the parts on either side by testing them all.
pub(super) fn naive(ctx: &mut BuildContext<'_>, node: &Aabb, parts: Vec<Part>) {
    recurse(ctx, node, 0, parts, &|search, parts| {
        let mut planes = Vec::with_capacity(2 * parts.len());
        for axis in 0..3 {
            if search.is_flat(axis) {
                continue;
            }
            planes.clear();
            for p in parts {
                planes.push(p.bounds.min[axis]);
                planes.push(p.bounds.max[axis]);
            }
            planes.sort_unstable_by(f32::total_cmp);
            planes.dedup();
            for &plane in &planes {
                let (mut below, mut above, mut planar) = (0, 0, 0);
                for p in parts {
                    let (lo, hi) = (p.bounds.min[axis], p.bounds.max[axis]);
                    below += usize::from(lo < plane);
                    above += usize::from(hi > plane);
                    planar += usize::from(lo == plane && hi == plane);
                }
                search.consider(axis, plane, below, above, planar);
            }
        }
    });
}

/// O(N log^2 N): each node makes and sorts its parts' events, then sweeps them as the event
/// build does.
pub(super) fn sort_each_level(ctx: &mut BuildContext<'_>, node: &Aabb, parts: Vec<Part>) {
    recurse(ctx, node, 0, parts, &|search, parts| {
        let mut events: Vec<Event> = Vec::with_capacity(2 * parts.len());
        for axis in 0..3 {
            events.clear();
            for p in parts {
                push_events(&mut events, axis, p);
            }
            sort_events(&mut events);
            sweep(axis, &events, parts.len(), search);
        }
    });
}

/// The top-down recursion both share: `price` gives the search every candidate plane of a
/// node's parts.
fn recurse(
    ctx: &mut BuildContext<'_>,
    node: &Aabb,
    depth: u32,
    parts: Vec<Part>,
    price: &dyn Fn(&mut super::split::SplitSearch<'_>, &[Part]),
) {
    let split = ctx.choose_split(node, depth, parts.len(), |search| price(search, &parts));
    let Some(split) = split else {
        ctx.leaf(&parts);
        return;
    };
    let [(below, _), (above, _)] = ctx.partition(&parts, node, &split, |_, _| {});
    drop(parts);
    let (below_box, above_box) = split.children(node);
    let at = ctx.open();
    recurse(ctx, &below_box, depth + 1, below, price);
    ctx.close(at, &split);
    recurse(ctx, &above_box, depth + 1, above, price);
}
