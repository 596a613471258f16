//! The Pareto front of time against error: the points no other point beats on both.

use crate::json::Point;
use std::collections::BTreeMap;

/// Marks `pareto` on every point that no other point of its plot (same scene, time and
/// quality measures) dominates: at most as slow and at most as bad, and better in one.
/// Points without a quality figure are never on the front.
pub fn mark(points: &mut [Point]) {
    let mut plots: BTreeMap<(String, String, String), Vec<usize>> = BTreeMap::new();
    for (i, p) in points.iter().enumerate() {
        plots
            .entry((p.scene.clone(), p.time_name.clone(), p.quality_name.clone()))
            .or_default()
            .push(i);
    }
    for members in plots.values() {
        let xy: Vec<Option<(f64, f64)>> = members
            .iter()
            .map(|&i| points[i].quality.map(|q| (points[i].time, q)))
            .collect();
        for (k, &i) in members.iter().enumerate() {
            points[i].pareto = xy[k].is_some_and(|p| !dominated(p, &xy));
        }
    }
}

/// True when some point of `all` dominates `p`.
pub fn dominated(p: (f64, f64), all: &[Option<(f64, f64)>]) -> bool {
    all.iter()
        .flatten()
        .any(|&(t, q)| t <= p.0 && q <= p.1 && (t < p.0 || q < p.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_keeps_only_undominated_points() {
        let all = [Some((1.0, 5.0)), Some((2.0, 2.0)), Some((3.0, 3.0)), None];
        assert!(!dominated((1.0, 5.0), &all));
        assert!(!dominated((2.0, 2.0), &all));
        assert!(dominated((3.0, 3.0), &all));
    }
}
