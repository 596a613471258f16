//! The measured half of the step aside (see [`AccelSettings::step_aside_when_slower`]): in a
//! world of any size that only culling uses, the trees step aside while Bevy's own passes,
//! timed beside them, cost less than the trees' upkeep and culling.
//!
//! Why measure and not model: which side wins depends on the share each view sees, on how
//! many entities move, and on the compute threads, across which Bevy's per-entity loop
//! spreads evenly and the trees' upkeep does not (BENCHMARKS.md, Whole frame); a player's
//! machine has a core count no threshold here was tuned on.
//!
//! How: while the trees are awake, a *probe frame* now and then runs Bevy's passes before the
//! trees' own (both write the same verdicts, so the later one's stand), and both are timed in
//! that frame. A few probes in a row in which Bevy's cost clearly less step the trees aside;
//! while aside, a *trial* wakes them now and then to probe again. Probes and trials grow rare
//! while the answer holds, so that a side that wins by far pays almost nothing for asking.
//!
//! [`AccelSettings::step_aside_when_slower`]: crate::AccelSettings::step_aside_when_slower

use core::sync::atomic::{AtomicU64, Ordering};
use core::time::Duration;

/// Frames the trees stay awake before their costs are first compared: a world's first frames
/// (its first builds, the automatic choice of index settling) are not what a frame costs.
const SETTLE_FRAMES: u32 = 30;
/// The same after a trial wakes the trees: the catch-up with every move made while aside,
/// and the views' first walks, are not what a frame costs either.
const TRIAL_SETTLE_FRAMES: u32 = 3;
/// Probes in a row that must find Bevy's passes cheaper before the trees step aside: one
/// frame's timing on a busy machine can be off by its whole cost.
const VOTES_TO_STEP_ASIDE: u32 = 3;
/// Frames between the probes that confirm a first finding.
const VOTE_SPACING: u32 = 4;
/// Frames between probes while the trees win, at first (doubled at the first probe they
/// win), and at most.
const PROBE_INTERVAL_MIN: u32 = 16;
const PROBE_INTERVAL_MAX: u32 = 2_048;
/// Frames aside before a trial wakes the trees, at first, and at most: short enough that a
/// camera that turns to a view the trees would win catches them up within seconds.
const ASIDE_INTERVAL_MIN: u32 = 64;
const ASIDE_INTERVAL_MAX: u32 = 512;

/// Bevy's passes must cost at most this share of the trees' for a probe to count against
/// the trees. A tie goes to Bevy's passes: what the timing leaves out is all on the trees'
/// side (the executor's hand-offs to two more systems, the trees' own footprint in the
/// caches), and in a probe frame the trees' culling runs second, over what Bevy's pass just
/// read (BENCHMARKS.md, Whole frame).
const BEVY_SHARE_TO_STEP_ASIDE: f64 = 1.0;
/// From this ratio of Bevy's cost to the trees' on, a probe's answer is taken as settled for
/// long, and the next probe put off by this factor instead of doubling.
const FAR_AHEAD_RATIO: f64 = 1.5;
const FAR_AHEAD_BACKOFF: u32 = 8;

/// One probe frame's costs: the trees' upkeep and culling, and Bevy's culling passes, each the
/// summed time of their systems in the same frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepAsideProbe {
    /// The trees' sync, maintenance, camera culling and light culling.
    pub trees: Duration,
    /// Bevy's `check_visibility_cpu_culling` and bevy_light's two caster tests.
    pub bevy: Duration,
}

/// The costs of the frame being run, added to by the systems of both sides.
#[derive(Default)]
pub(crate) struct FrameCosts {
    trees_nanos: AtomicU64,
    bevy_nanos: AtomicU64,
}

impl FrameCosts {
    /// Adds the time of one of the trees' systems.
    #[inline]
    pub(crate) fn add_trees(&self, time: Duration) {
        self.trees_nanos
            .fetch_add(time.as_nanos() as u64, Ordering::Relaxed);
    }

    /// Adds the time of one of Bevy's passes that stand in for the trees'.
    #[inline]
    #[cfg_attr(not(feature = "culling"), allow(dead_code))]
    pub(crate) fn add_bevy(&self, time: Duration) {
        self.bevy_nanos
            .fetch_add(time.as_nanos() as u64, Ordering::Relaxed);
    }

    /// The last frame's costs, and a fresh count for this one.
    pub(crate) fn take(&self) -> StepAsideProbe {
        StepAsideProbe {
            trees: Duration::from_nanos(self.trees_nanos.swap(0, Ordering::Relaxed)),
            bevy: Duration::from_nanos(self.bevy_nanos.swap(0, Ordering::Relaxed)),
        }
    }
}

/// What a frame does, as the probe decides it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ProbeVerdict {
    /// The trees alone.
    Awake,
    /// The trees, and Bevy's passes before them, both timed.
    Probe,
    /// Bevy's passes alone.
    Aside,
}

/// The probe's state from frame to frame.
#[derive(Clone, Debug)]
pub(crate) struct CostProbe {
    /// Frames still to wait, awake, before the next probe may come.
    settle_left: u32,
    /// Frames to the next probe while awake, or to the next trial while aside.
    countdown: u32,
    probe_interval: u32,
    aside_interval: u32,
    /// Probes in a row that found Bevy's passes cheaper.
    votes: u32,
    aside: bool,
    /// The last frame was a probe frame.
    probing: bool,
    last: Option<StepAsideProbe>,
}

impl Default for CostProbe {
    fn default() -> Self {
        Self {
            settle_left: SETTLE_FRAMES,
            countdown: 1,
            probe_interval: PROBE_INTERVAL_MIN,
            aside_interval: ASIDE_INTERVAL_MIN,
            votes: 0,
            aside: false,
            probing: false,
            last: None,
        }
    }
}

impl CostProbe {
    /// The last probe frame's costs.
    pub(crate) fn last(&self) -> Option<StepAsideProbe> {
        self.last
    }

    /// Forgets the state of the world it measured (it became small, gained a reader, or the
    /// setting was turned off): the trees are awake, and a later probe starts afresh. The
    /// last probe's figures stay, for whoever reads them.
    pub(crate) fn reset(&mut self) {
        *self = Self {
            last: self.last,
            ..Self::default()
        };
    }

    /// Decides this frame from the last frame's `costs`.
    pub(crate) fn next(&mut self, costs: StepAsideProbe) -> ProbeVerdict {
        if core::mem::take(&mut self.probing) {
            self.last = Some(costs);
            if self.weigh(costs) {
                return ProbeVerdict::Aside;
            }
        }
        if self.aside {
            self.countdown -= 1;
            if self.countdown > 0 {
                return ProbeVerdict::Aside;
            }
            // A trial: awake again, probing as soon as the catch-up has settled.
            self.aside = false;
            self.settle_left = TRIAL_SETTLE_FRAMES;
            self.countdown = 1;
            return ProbeVerdict::Awake;
        }
        if self.settle_left > 0 {
            self.settle_left -= 1;
            return ProbeVerdict::Awake;
        }
        self.countdown -= 1;
        if self.countdown > 0 {
            return ProbeVerdict::Awake;
        }
        self.probing = true;
        ProbeVerdict::Probe
    }

    /// Weighs one probe frame's costs; true when they step the trees aside.
    fn weigh(&mut self, costs: StepAsideProbe) -> bool {
        let trees = costs.trees.as_secs_f64();
        let bevy = costs.bevy.as_secs_f64();
        if bevy <= trees * BEVY_SHARE_TO_STEP_ASIDE {
            self.votes += 1;
            if self.votes < VOTES_TO_STEP_ASIDE {
                self.countdown = VOTE_SPACING;
                return false;
            }
            self.votes = 0;
            self.aside = true;
            self.countdown = self.aside_interval;
            // Found cheaper again after a trial: the next trial comes later.
            self.aside_interval = (self.aside_interval * 2).min(ASIDE_INTERVAL_MAX);
            self.probe_interval = PROBE_INTERVAL_MIN;
            return true;
        }
        self.votes = 0;
        self.aside_interval = ASIDE_INTERVAL_MIN;
        let backoff = if bevy >= trees * FAR_AHEAD_RATIO {
            FAR_AHEAD_BACKOFF
        } else {
            2
        };
        self.probe_interval = (self.probe_interval * backoff).min(PROBE_INTERVAL_MAX);
        self.countdown = self.probe_interval;
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn costs(trees_us: u64, bevy_us: u64) -> StepAsideProbe {
        StepAsideProbe {
            trees: Duration::from_micros(trees_us),
            bevy: Duration::from_micros(bevy_us),
        }
    }

    /// Runs `frames` frames, feeding each the costs a frame of its verdict would report;
    /// returns the verdicts.
    fn run(probe: &mut CostProbe, frames: usize, trees_us: u64, bevy_us: u64) -> Vec<ProbeVerdict> {
        let mut last = ProbeVerdict::Awake;
        let mut verdicts = Vec::with_capacity(frames);
        for _ in 0..frames {
            let reported = match last {
                ProbeVerdict::Awake => costs(trees_us, 0),
                ProbeVerdict::Probe => costs(trees_us, bevy_us),
                ProbeVerdict::Aside => costs(0, bevy_us),
            };
            last = probe.next(reported);
            verdicts.push(last);
        }
        verdicts
    }

    fn count(verdicts: &[ProbeVerdict], which: ProbeVerdict) -> usize {
        verdicts.iter().filter(|v| **v == which).count()
    }

    #[test]
    fn trees_that_win_stay_awake_and_probe_ever_more_rarely() {
        let mut probe = CostProbe::default();
        let verdicts = run(&mut probe, 20_000, 100, 120);
        assert_eq!(count(&verdicts, ProbeVerdict::Aside), 0);
        let probes: Vec<usize> = (0..verdicts.len())
            .filter(|&i| verdicts[i] == ProbeVerdict::Probe)
            .collect();
        assert_eq!(probes[0], SETTLE_FRAMES as usize);
        let gaps: Vec<usize> = probes.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(gaps.windows(2).all(|g| g[1] >= g[0]), "{gaps:?}");
        assert_eq!(*gaps.last().unwrap(), PROBE_INTERVAL_MAX as usize);
        assert_eq!(probe.last(), Some(costs(100, 120)));
    }

    #[test]
    fn trees_far_ahead_back_off_at_once() {
        let mut probe = CostProbe::default();
        let verdicts = run(&mut probe, 1_000, 100, 400);
        // The first probe, then one a whole backed-off interval later.
        assert_eq!(count(&verdicts, ProbeVerdict::Probe), 2);
    }

    #[test]
    fn cheaper_bevy_steps_aside_after_confirming_probes() {
        let mut probe = CostProbe::default();
        let verdicts = run(&mut probe, 60, 100, 50);
        let first_aside = verdicts
            .iter()
            .position(|v| *v == ProbeVerdict::Aside)
            .unwrap();
        assert_eq!(count(&verdicts[..first_aside], ProbeVerdict::Probe), 3);
        assert!(
            verdicts[first_aside..]
                .iter()
                .all(|v| *v == ProbeVerdict::Aside)
        );
    }

    #[test]
    fn a_tie_goes_to_bevys_passes_and_a_narrow_win_to_the_trees() {
        let mut probe = CostProbe::default();
        let verdicts = run(&mut probe, 200, 100, 100);
        assert!(count(&verdicts, ProbeVerdict::Aside) > 100);
        let mut probe = CostProbe::default();
        let verdicts = run(&mut probe, 5_000, 100, 105);
        assert_eq!(count(&verdicts, ProbeVerdict::Aside), 0);
    }

    #[test]
    fn one_cheap_probe_among_dear_ones_does_not_step_aside() {
        let mut probe = CostProbe::default();
        let mut last = ProbeVerdict::Awake;
        let mut probes = 0;
        for _ in 0..5_000 {
            let reported = if last == ProbeVerdict::Probe {
                probes += 1;
                // Every other probe finds Bevy cheaper: never three in a row.
                if probes % 2 == 0 {
                    costs(100, 50)
                } else {
                    costs(100, 120)
                }
            } else {
                costs(100, 0)
            };
            last = probe.next(reported);
            assert_ne!(last, ProbeVerdict::Aside);
        }
    }

    #[test]
    fn trials_wake_the_trees_and_return_while_bevy_stays_cheaper() {
        let mut probe = CostProbe::default();
        let verdicts = run(&mut probe, 4_000, 100, 50);
        let first_aside = verdicts
            .iter()
            .position(|v| *v == ProbeVerdict::Aside)
            .unwrap();
        let after = &verdicts[first_aside..];
        // Trials wake the trees now and then, for the settling frames and three probes.
        let woken = count(after, ProbeVerdict::Awake) + count(after, ProbeVerdict::Probe);
        assert!(woken > 0);
        assert!(
            count(after, ProbeVerdict::Aside) > 20 * woken,
            "{woken} frames awake"
        );
        assert_eq!(*verdicts.last().unwrap(), ProbeVerdict::Aside);
    }

    #[test]
    fn a_trial_that_finds_the_trees_cheaper_keeps_them_awake() {
        let mut probe = CostProbe::default();
        run(&mut probe, 200, 100, 50);
        assert!(probe.aside);
        let verdicts = run(&mut probe, 2_000, 100, 200);
        let last_aside = verdicts
            .iter()
            .rposition(|v| *v == ProbeVerdict::Aside)
            .unwrap();
        assert!(last_aside < ASIDE_INTERVAL_MAX as usize, "{last_aside}");
        assert!(!probe.aside);
    }

    #[test]
    fn reset_wakes_the_trees_and_keeps_the_last_figures() {
        let mut probe = CostProbe::default();
        run(&mut probe, 200, 100, 50);
        probe.reset();
        assert!(!probe.aside);
        assert_eq!(probe.last(), Some(costs(100, 50)));
        assert_eq!(probe.next(costs(0, 0)), ProbeVerdict::Awake);
    }
}
