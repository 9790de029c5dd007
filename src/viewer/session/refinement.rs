//! The session's side of progressive refinement: the plan in refinement order, restarts when
//! the state's version changes (or, after interaction stopped, to leave the preview size), and
//! which GPU timings belong to which refinement. The schedule itself (batch sizes, preview
//! size) is [`Refiner`]'s.

use std::time::Instant;

use glam::DVec2;

use super::super::gpu::FrameTiming;
use super::super::refine::{spread_order, Batch, Refiner};
use super::stats::Stats;
use crate::refocus::antialias::AntialiasPlan;
use crate::refocus::RefocusPlan;

/// One frame's refinement work, decided before it is recorded.
#[derive(Debug, Clone)]
pub struct FramePlan {
    /// Views to add, if refinement is not complete.
    pub batch: Option<Batch>,
    /// Input was arriving (the batch is sized for the frame budget).
    pub interactive: bool,
}

impl FramePlan {
    /// The batch is at full output size.
    pub fn full_size(&self) -> bool {
        self.batch.as_ref().is_some_and(|b| b.divisor == 1)
    }
}

/// Refinement of the current state.
pub struct Refinement {
    pub refiner: Refiner,
    /// The state's plan with its views in refinement order (the batches index it): the
    /// anti-aliasing plan's views when it is on.
    pub ordered: RefocusPlan,
    /// The anti-aliasing plan in the same order, when it is on.
    pub ordered_aa: Option<AntialiasPlan>,
    /// The state version `ordered` was made from.
    version: u64,
    /// Counts restarts; frame timings carry it, so only this refinement's add up.
    pub id: u32,
    /// GPU time of this refinement's full-size frames so far.
    gpu_ms: f64,
    /// When this refinement started at full size (to time it to full quality).
    started: Option<Instant>,
    /// The last frame's GPU time (the status line's).
    pub last_gpu_ms: Option<f64>,
}

/// The refinement order of `plan`'s views.
fn refinement_order(plan: &RefocusPlan) -> Vec<usize> {
    let positions: Vec<DVec2> = plan
        .views
        .iter()
        .map(|v| DVec2::new(v.s as f64, v.t as f64))
        .collect();
    spread_order(&positions, plan.reference)
}

/// The plan with its views in refinement order.
fn refinement_plan(plan: &RefocusPlan) -> RefocusPlan {
    let order = refinement_order(plan);
    let mut p = plan.clone();
    p.views = order.iter().map(|&i| plan.views[i]).collect();
    p
}

/// The anti-aliasing plan with its views (and their footprints) in refinement order.
fn refinement_aa(aa: &AntialiasPlan) -> AntialiasPlan {
    let order = refinement_order(&aa.plan);
    let mut a = aa.clone();
    a.plan.views = order.iter().map(|&i| aa.plan.views[i]).collect();
    a.footprints = order.iter().map(|&i| aa.footprints[i]).collect();
    a
}

impl Refinement {
    pub fn new(refiner: Refiner, plan: &RefocusPlan) -> Self {
        Refinement {
            refiner,
            ordered: refinement_plan(plan),
            ordered_aa: None,
            // No version yet: the first frame starts a refinement.
            version: u64::MAX,
            id: 0,
            gpu_ms: 0.0,
            started: None,
            last_gpu_ms: None,
        }
    }

    /// `version` is the one being refined.
    pub fn is_current(&self, version: u64) -> bool {
        self.version == version
    }

    /// Restarts after a change of the state (`plan` at `version`, anti-aliased by `aa` when
    /// given), or at full size once the input stopped; true when the state changed.
    pub fn update(
        &mut self,
        plan: &RefocusPlan,
        aa: Option<&AntialiasPlan>,
        version: u64,
        interactive: bool,
    ) -> bool {
        if version != self.version {
            self.ordered_aa = aa.map(refinement_aa);
            self.ordered = match &self.ordered_aa {
                Some(a) => a.plan.clone(),
                None => refinement_plan(plan),
            };
            self.version = version;
            self.refiner.restart(self.ordered.views.len(), interactive);
            self.begin((self.refiner.divisor() == 1).then(Instant::now));
            true
        } else {
            if !interactive && self.refiner.divisor() > 1 {
                self.refiner.restart(self.ordered.views.len(), false);
                self.begin(Some(Instant::now()));
            }
            false
        }
    }

    fn begin(&mut self, started: Option<Instant>) {
        self.id += 1;
        self.gpu_ms = 0.0;
        self.started = started;
    }

    /// Feeds a completed frame's GPU times to the schedule and the statistics.
    pub fn measured(&mut self, t: &FrameTiming, stats: &mut Stats) {
        log::debug!(
            "frame: {} views at 1/{}: accumulate {:.1} ms, frame {:.1} ms (GPU)",
            t.views,
            t.divisor,
            t.accumulate_ms,
            t.frame_ms
        );
        // Reduced-size previews of an anti-aliased refinement are plain sums (Session::draw):
        // their cost says nothing about the anti-aliased frames the schedule plans.
        if !(t.divisor > 1 && self.ordered_aa.is_some()) {
            self.refiner
                .measured(t.views, t.divisor, t.accumulate_ms, t.frame_ms);
        }
        self.last_gpu_ms = Some(t.frame_ms);
        let (id, was_interactive) = t.tag;
        if was_interactive {
            stats.interactive_ms.push(t.frame_ms);
        }
        if t.divisor == 1 && id == self.id {
            self.gpu_ms += t.frame_ms;
        }
    }

    /// Full quality reached: records how long this refinement took (once).
    pub fn converged(&mut self, stats: &mut Stats) {
        if let Some(t0) = self.started.take() {
            stats.full_wall_ms.push(t0.elapsed().as_secs_f64() * 1e3);
            stats.full_gpu_ms.push(self.gpu_ms);
        }
    }
}
