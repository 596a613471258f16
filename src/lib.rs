//! bevy_accel
use bevy::prelude::*;
pub struct AccelPlugin;
impl Plugin for AccelPlugin { fn build(&self, _app: &mut App) {} }
