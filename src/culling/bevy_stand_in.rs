//! Bevy's own culling passes, kept beside the trees' to stand in for them while the trees
//! stand aside (`AccelTrees::stepped_aside`), and timed, so that the measured choice of
//! `AccelSettings::step_aside_when_slower` weighs them against the trees' in the same frame.

use crate::trees::FrameCosts;
use bevy::ecs::system::{Adapt, IntoAdapterSystem, RunSystemError, System, SystemIn};
use bevy::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// Times the system it wraps into the frame's costs of Bevy's side. Wrapping keeps the
/// system's own type among its sets, so Bevy's orderings by that type still hold.
#[derive(Clone)]
pub(super) struct TimedStandIn(Arc<FrameCosts>);

impl<S: System<In = ()>> Adapt<S> for TimedStandIn {
    type In = ();
    type Out = S::Out;

    fn adapt(
        &mut self,
        (): (),
        run_system: impl FnOnce(SystemIn<'_, S>) -> Result<S::Out, RunSystemError>,
    ) -> Result<S::Out, RunSystemError> {
        let start = Instant::now();
        let out = run_system(());
        self.0.add_bevy(start.elapsed());
        out
    }
}

/// Bevy's `system`, timed into the frame's costs of `app`'s trees (untimed in an app without
/// them, where it only stands in).
pub(super) fn timed_stand_in<S, M>(app: &App, system: S) -> IntoAdapterSystem<TimedStandIn, S>
where
    S: IntoSystem<(), (), M>,
{
    let costs = app
        .world()
        .get_resource::<crate::AccelTrees>()
        .map(|trees| trees.step_aside.costs().clone())
        .unwrap_or_default();
    IntoAdapterSystem::new(TimedStandIn(costs), system)
}
