//! Camera views: the system that replaces Bevy's `check_visibility_cpu_culling`, and its
//! passes.
//!
//! - `system`: per view, chooses the tree path or the flat pass and runs it.
//! - `view_walk`: a view's last tree walk, kept for the next frame.
//! - Tree path: `found_pass` decides what a walk found, through `view_pass` (Bevy's rules
//!   and frustum test for one entity) or straight from Bevy's table columns at remembered
//!   rows (`table_rows`, which holds the plugin's only `unsafe` column access).
//! - Flat path: `flat_pass` goes through every cullable entity in table order, for views
//!   that see most of the world, with `tree_verdicts` (the trees' word on its frustum tests).

mod flat_pass;
mod found_pass;
mod system;
mod table_rows;
mod tree_verdicts;
mod view_pass;
mod view_walk;

pub(super) use system::cull_views_with_trees;
