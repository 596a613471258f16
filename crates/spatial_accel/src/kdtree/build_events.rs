//! The O(N log N) build of Wald and Havran 2006 (section 4.3): the events of every triangle
//! are sorted once, at the root; each node finds its split with one sweep over its three
//! sorted lists, and hands each child its share of them in the same order, so no list is
//! sorted again. Only the triangles the split crosses get new events (from their clipped
//! parts), which are few: sorted on their own and merged in.

use super::builder::BuildContext;
use super::split::{Part, Side, SplitSearch};
use crate::Aabb;

/// What an event marks; the order is the sweep's order at one position.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum EventKind {
    /// A part's box ends here.
    End,
    /// A part's box is flat here (it lies in the plane).
    Planar,
    /// A part's box starts here.
    Start,
}

/// One end (or the flat extent) of a part's box on one axis.
#[derive(Clone, Copy, Debug)]
pub(super) struct Event {
    pub position: f32,
    pub triangle: u32,
    pub kind: EventKind,
}

/// The sweep's order: by position, then kind, then triangle (the last only so that every
/// sort gives one order).
#[inline]
fn before(a: &Event, b: &Event) -> core::cmp::Ordering {
    a.position
        .total_cmp(&b.position)
        .then(a.kind.cmp(&b.kind))
        .then(a.triangle.cmp(&b.triangle))
}

/// Appends `part`'s events on `axis`: a start and an end, or one planar event.
#[inline]
pub(super) fn push_events(events: &mut Vec<Event>, axis: usize, part: &Part) {
    let (lo, hi) = (part.bounds.min[axis], part.bounds.max[axis]);
    let event = |position, kind| Event {
        position,
        triangle: part.triangle,
        kind,
    };
    if lo == hi {
        events.push(event(lo, EventKind::Planar));
    } else {
        events.push(event(lo, EventKind::Start));
        events.push(event(hi, EventKind::End));
    }
}

/// Sorts events into the sweep's order.
pub(super) fn sort_events(events: &mut [Event]) {
    events.sort_unstable_by(before);
}

/// Feeds `search` every plane on `axis` at which `events` (sorted, the events of `n` parts)
/// has one, in increasing order, with the counts of parts below, above and in it.
pub(super) fn sweep(axis: usize, events: &[Event], n: usize, search: &mut SplitSearch<'_>) {
    if search.is_flat(axis) {
        return;
    }
    let (mut below, mut above) = (0, n);
    let mut i = 0;
    while i < events.len() {
        let position = events[i].position;
        let (mut ends, mut planar, mut starts) = (0, 0, 0);
        while i < events.len() && events[i].position == position {
            match events[i].kind {
                EventKind::End => ends += 1,
                EventKind::Planar => planar += 1,
                EventKind::Start => starts += 1,
            }
            i += 1;
        }
        above -= ends + planar;
        search.consider(axis, position, below, above, planar);
        below += starts + planar;
    }
}

/// Builds with the event sweep.
pub(super) fn event_sweep(ctx: &mut BuildContext<'_>, root: &Aabb, parts: Vec<Part>) {
    let events = [0, 1, 2].map(|axis| {
        let mut list = Vec::with_capacity(2 * parts.len());
        for part in &parts {
            push_events(&mut list, axis, part);
        }
        sort_events(&mut list);
        list
    });
    // Each triangle's side at the split being made: written by the classification, read
    // while the events are divided, before any child is built.
    let mut sides = vec![Side::Below; ctx.corners.len()];
    build_node(ctx, root, 0, parts, events, &mut sides);
}

fn build_node(
    ctx: &mut BuildContext<'_>,
    node: &Aabb,
    depth: u32,
    parts: Vec<Part>,
    events: [Vec<Event>; 3],
    sides: &mut [Side],
) {
    let n = parts.len();
    let split = ctx.choose_split(node, depth, n, |search| {
        for (axis, list) in events.iter().enumerate() {
            sweep(axis, list, n, search);
        }
    });
    let Some(split) = split else {
        ctx.leaf(&parts);
        return;
    };
    let [(below, below_clipped), (above, above_clipped)] =
        ctx.partition(&parts, node, &split, |t, side| sides[t as usize] = side);
    drop(parts);
    let mut below_events: [Vec<Event>; 3] = Default::default();
    let mut above_events: [Vec<Event>; 3] = Default::default();
    for (axis, list) in events.into_iter().enumerate() {
        let [b, a] = divide_events(
            axis,
            list,
            sides,
            [&below[below_clipped..], &above[above_clipped..]],
        );
        below_events[axis] = b;
        above_events[axis] = a;
    }
    let (below_box, above_box) = split.children(node);
    let at = ctx.open();
    build_node(ctx, &below_box, depth + 1, below, below_events, sides);
    ctx.close(at, &split);
    build_node(ctx, &above_box, depth + 1, above, above_events, sides);
}

/// One axis's sorted events divided between the children: the events of parts wholly on
/// one side go there in order (a linear pass keeps them sorted), those of crossing parts are
/// dropped, and the events of the crossing parts' clipped pieces (`clipped`, per side) are
/// sorted on their own and merged in.
fn divide_events(
    axis: usize,
    events: Vec<Event>,
    sides: &[Side],
    clipped: [&[Part]; 2],
) -> [Vec<Event>; 2] {
    let (mut below, mut above) = (Vec::new(), Vec::new());
    for e in events {
        match sides[e.triangle as usize] {
            Side::Below => below.push(e),
            Side::Above => above.push(e),
            Side::Both => {}
        }
    }
    [(below, clipped[0]), (above, clipped[1])].map(|(kept, pieces)| {
        let mut fresh = Vec::with_capacity(2 * pieces.len());
        for part in pieces {
            push_events(&mut fresh, axis, part);
        }
        if fresh.is_empty() {
            return kept;
        }
        sort_events(&mut fresh);
        merge(kept, fresh)
    })
}

/// Merges two sorted event lists.
fn merge(a: Vec<Event>, b: Vec<Event>) -> Vec<Event> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if before(&b[j], &a[i]).is_lt() {
            out.push(b[j]);
            j += 1;
        } else {
            out.push(a[i]);
            i += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}
