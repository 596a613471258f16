//! Camera views: the system that replaces Bevy's `check_visibility_cpu_culling`, and its
//! passes.
//!
//! - `system`: per view, chooses the tree path or the flat pass and runs it.
//! - `flat_pass`: every cullable entity in table order, for views that see most of the world.
//! - `view_walk`: a view's last tree walk, kept for the next frame.
//! - `found_pass`, `tree_pass`, `table_rows`: deciding what a walk found, straight from
//!   Bevy's table columns at remembered rows (`table_rows` holds the plugin's only `unsafe`
//!   column access).

mod flat_pass;
mod found_pass;
mod system;
mod table_rows;
mod tree_pass;
mod view_walk;

pub(super) use system::cull_views_with_trees;
