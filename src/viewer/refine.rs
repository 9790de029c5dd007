//! Progressive refinement: after any change the accumulation restarts and every frame adds the
//! next batch of views, presenting the normalised partial sum, until the whole aperture is in.
//!
//! - Order ([`spread_order`]): views are taken so that each next one is the farthest (in grid
//!   units) from those already taken, starting at the view nearest the reference. The first few
//!   views already span the aperture, so early frames show the right amount of blur (with some
//!   ghosting), not a sharp pinhole image that suddenly blurs.
//! - Batch size: a cost model fitted to the GPU timestamps of earlier frames — milliseconds per
//!   view and output pixel, plus a per-frame overhead — gives how many views fit the frame
//!   budget. While the user interacts the budget is the frame budget; once the view is still,
//!   refinement frames may take [`STILL_BUDGET_FACTOR`] budgets, and more where needed to
//!   keep the per-frame overhead (resolve, scene, compositing, present) under
//!   [`STILL_OVERHEAD_FRACTION`] of the frame, up to [`MAX_STILL_FRAME_MS`]: fewer, larger
//!   batches reach full quality sooner, and a new input is answered after at most one such
//!   frame.
//! - Preview size: while interacting on a device too slow for [`PREVIEW_VIEWS`] views per frame
//!   at full size, the output shrinks by an integer factor (up to [`MAX_PREVIEW_DIVISOR`]) so
//!   the batch gets there; full size resumes as soon as the input stops. The first frame after
//!   a change has at least [`PREVIEW_MIN_VIEWS`] views even where the frame's fixed cost alone
//!   exceeds the budget: an over-budget frame that looks like the final image, not one view.

use std::ops::Range;

use glam::DVec2;

/// Views per interactive frame the preview size aims for.
pub const PREVIEW_VIEWS: usize = 12;
/// Fewest views in the first frame after a change, whatever the budget: the first views of
/// [`spread_order`] span the aperture, so even an over-budget preview shows the defocus of the
/// final image instead of a sharp, noisy pinhole view.
pub const PREVIEW_MIN_VIEWS: usize = 9;
/// Largest preview shrink factor (per axis).
pub const MAX_PREVIEW_DIVISOR: u32 = 4;
/// Budgets a refinement frame may take once the input has stopped.
pub const STILL_BUDGET_FACTOR: f64 = 3.0;
/// Once still, batches grow until the per-frame overhead is at most this fraction of a frame,
/// so refinement reaches full quality in little more than the one-pass time…
pub const STILL_OVERHEAD_FRACTION: f64 = 0.1;
/// …but no still frame is planned longer than this (the next input waits for it).
pub const MAX_STILL_FRAME_MS: f64 = 400.0;

/// Whether the window switches to the target `batch` was summed into, of a plan of `total`
/// views: a preview always; a full-size sum once it has [`PREVIEW_MIN_VIEWS`] views (or all),
/// or when no preview exists to keep showing.
pub fn shows_batch(batch: &Batch, total: usize, preview_ready: bool) -> bool {
    batch.divisor > 1 || batch.views.end >= PREVIEW_MIN_VIEWS.min(total) || !preview_ready
}

/// The order in which to accumulate views at grid `positions` for a reference at `centre`.
pub fn spread_order(positions: &[DVec2], centre: DVec2) -> Vec<usize> {
    let n = positions.len();
    let mut order = Vec::with_capacity(n);
    if n == 0 {
        return order;
    }
    let first = (0..n)
        .min_by(|&a, &b| {
            (positions[a] - centre)
                .length()
                .total_cmp(&(positions[b] - centre).length())
        })
        .expect("n > 0");
    let mut nearest = vec![f64::INFINITY; n];
    let mut taken = vec![false; n];
    let mut next = first;
    for _ in 0..n {
        taken[next] = true;
        order.push(next);
        for i in 0..n {
            nearest[i] = nearest[i].min((positions[i] - positions[next]).length());
        }
        // Farthest from everything taken; ties go to the lower index (deterministic).
        let mut best: Option<usize> = None;
        for i in (0..n).filter(|&i| !taken[i]) {
            if best.map_or(true, |b| nearest[i] > nearest[b]) {
                best = Some(i);
            }
        }
        match best {
            Some(b) => next = b,
            None => break,
        }
    }
    order
}

/// One frame's share of the refinement.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Batch {
    /// Views (positions in the refinement order) to add.
    pub views: Range<usize>,
    /// Start from zero (first batch after a restart).
    pub clear: bool,
    /// Output shrink factor (1 = full size).
    pub divisor: u32,
}

/// The refinement schedule and its cost model.
#[derive(Debug, Clone)]
pub struct Refiner {
    budget_ms: f64,
    total: usize,
    done: usize,
    divisor: u32,
    /// Accumulation time against view·megapixels: a fixed cost per batch (clearing and
    /// reading back the float target, the draw itself) plus a cost per view·Mpx.
    fit: CostFit,
    /// GPU ms per frame besides the accumulation (resolve, scene, compositing).
    overhead_ms: Option<f64>,
    full_pixels: f64,
    /// Views of the last batch planned.
    last_batch: usize,
}

/// Least-squares line through recent (x, y) samples, older ones forgotten geometrically, so
/// the model follows a device whose speed changes (load, clocks).
#[derive(Debug, Clone, Copy, Default)]
struct CostFit {
    n: f64,
    sx: f64,
    sy: f64,
    sxx: f64,
    sxy: f64,
}

impl CostFit {
    const KEEP: f64 = 0.85;

    fn add(&mut self, x: f64, y: f64) {
        let k = Self::KEEP;
        self.n = k * self.n + 1.0;
        self.sx = k * self.sx + x;
        self.sy = k * self.sy + y;
        self.sxx = k * self.sxx + x * x;
        self.sxy = k * self.sxy + x * y;
    }

    /// Whether the samples spread in x enough to separate the fixed cost from the slope.
    fn spread(&self) -> bool {
        self.n > 0.0 && self.sxx > 0.0 && self.sxx - self.sx * self.sx / self.n > 1e-3 * self.sxx
    }

    /// (fixed, slope); through the origin while the samples do not spread in x.
    fn line(&self) -> Option<(f64, f64)> {
        if self.n <= 0.0 || self.sx <= 0.0 {
            return None;
        }
        let var = self.sxx - self.sx * self.sx / self.n;
        if var > 1e-3 * self.sxx {
            let slope = (self.sxy - self.sx * self.sy / self.n) / var;
            let fixed = (self.sy - slope * self.sx) / self.n;
            if slope > 0.0 && fixed >= 0.0 {
                return Some((fixed, slope));
            }
        }
        Some((0.0, (self.sy / self.sx).max(1e-9)))
    }
}

impl Refiner {
    /// A schedule for `budget_ms` frames and outputs of `full_pixels` at full size.
    pub fn new(budget_ms: f64, full_pixels: u64) -> Self {
        Refiner {
            budget_ms,
            total: 0,
            done: 0,
            divisor: 1,
            fit: CostFit::default(),
            overhead_ms: None,
            full_pixels: full_pixels.max(1) as f64,
            last_batch: 0,
        }
    }

    /// Starts again with `total` views; `interactive` allows a preview size.
    pub fn restart(&mut self, total: usize, interactive: bool) {
        self.total = total;
        self.done = 0;
        self.divisor = if interactive {
            self.preview_divisor()
        } else {
            1
        };
    }

    /// Views accumulated so far, and the aperture's total.
    pub fn progress(&self) -> (usize, usize) {
        (self.done, self.total)
    }

    /// The current output shrink factor.
    pub fn divisor(&self) -> u32 {
        self.divisor
    }

    /// Whether every view is in at full size.
    pub fn converged(&self) -> bool {
        self.done >= self.total && self.divisor == 1
    }

    /// Whether every view is in at the current size.
    pub fn complete(&self) -> bool {
        self.done >= self.total
    }

    /// Predicted GPU ms of one more view at `divisor`, once measured.
    fn per_view_ms(&self, divisor: u32) -> Option<f64> {
        let mpx = self.full_pixels / (divisor * divisor) as f64 / 1e6;
        self.fit.line().map(|(_, b)| (b * mpx).max(1e-6))
    }

    /// Predicted GPU ms of a frame besides its views: the batch's fixed cost and the rest.
    fn frame_overhead_ms(&self) -> f64 {
        let fixed = self.fit.line().map_or(0.0, |(a, _)| a);
        fixed + self.overhead_ms.unwrap_or(0.0)
    }

    fn views_within(&self, budget_ms: f64, divisor: u32) -> usize {
        let Some(per_view) = self.per_view_ms(divisor) else {
            // No measurement yet: one view, which measures the device.
            return 1;
        };
        (((budget_ms - self.frame_overhead_ms()).max(0.0) / per_view).floor() as usize).max(1)
    }

    fn preview_divisor(&self) -> u32 {
        let want = PREVIEW_VIEWS.min(self.total.max(1));
        (1..=MAX_PREVIEW_DIVISOR)
            .find(|&d| self.views_within(self.budget_ms, d) >= want)
            .unwrap_or(MAX_PREVIEW_DIVISOR)
    }

    /// The next batch, or `None` when complete. `interactive`: the user is giving input now
    /// (the frame budget applies); otherwise the longer still budget does.
    pub fn next_batch(&mut self, interactive: bool) -> Option<Batch> {
        if self.complete() {
            return None;
        }
        let mut n = if interactive {
            let by_budget = self.views_within(self.budget_ms, self.divisor);
            // Once the device is measured (the very first frame measures it with one view).
            if self.done == 0 && self.per_view_ms(self.divisor).is_some() {
                by_budget.max(PREVIEW_MIN_VIEWS)
            } else {
                by_budget
            }
        } else {
            let by_budget = self.views_within(self.budget_ms * STILL_BUDGET_FACTOR, self.divisor);
            match self.per_view_ms(self.divisor) {
                Some(per_view) => {
                    let by_overhead = (self.frame_overhead_ms() * (1.0 - STILL_OVERHEAD_FRACTION)
                        / STILL_OVERHEAD_FRACTION
                        / per_view)
                        .ceil() as usize;
                    // The cap counts the batch's fixed cost too: the frame is what the next
                    // input waits for.
                    let fixed = self.fit.line().map_or(0.0, |(a, _)| a);
                    let cap = (((MAX_STILL_FRAME_MS - fixed).max(0.0) / per_view).floor() as usize)
                        .max(1);
                    let n = by_budget.max(by_overhead.min(cap));
                    // Batches of one size cannot tell a batch's fixed cost (anti-aliasing's
                    // focus test reads every view whatever the batch) from the cost per view,
                    // and the line through the origin then charges it all per view: one view
                    // per frame for ever. Doubling the batch until the sizes spread measures
                    // both.
                    match self.fit.spread() {
                        true => n,
                        false => n.max(2 * self.last_batch),
                    }
                }
                None => by_budget,
            }
        };
        n = n.min(self.total - self.done);
        self.last_batch = n;
        let batch = Batch {
            views: self.done..self.done + n,
            clear: self.done == 0,
            divisor: self.divisor,
        };
        self.done += n;
        Some(batch)
    }

    /// Feeds the GPU times of a finished frame that accumulated `views` views at `divisor`
    /// (`accumulate_ms`) and took `frame_ms` in all.
    pub fn measured(&mut self, views: usize, divisor: u32, accumulate_ms: f64, frame_ms: f64) {
        if views == 0 || !(accumulate_ms.is_finite() && frame_ms.is_finite()) {
            return;
        }
        let mpx = self.full_pixels / (divisor * divisor) as f64 / 1e6;
        self.fit.add(views as f64 * mpx, accumulate_ms);
        // An exponential average: follows the device without jumping on one frame.
        let overhead = (frame_ms - accumulate_ms).max(0.0);
        self.overhead_ms = Some(match self.overhead_ms {
            Some(old) => 0.7 * old + 0.3 * overhead,
            None => overhead,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize) -> Vec<DVec2> {
        (0..n * n)
            .map(|i| DVec2::new((i % n) as f64, (i / n) as f64))
            .collect()
    }

    #[test]
    fn the_order_is_a_permutation_that_spreads_early() {
        let g = grid(9);
        let order = spread_order(&g, DVec2::new(4.0, 4.0));
        let mut sorted = order.clone();
        sorted.sort();
        assert_eq!(sorted, (0..81).collect::<Vec<_>>());
        assert_eq!(order[0], 40, "starts at the centre view");
        // The first five views reach the corners: they span the whole aperture.
        let first: Vec<DVec2> = order[..5].iter().map(|&i| g[i]).collect();
        let (min, max) = first
            .iter()
            .fold((DVec2::splat(9.0), DVec2::splat(-1.0)), |(a, b), p| {
                (a.min(*p), b.max(*p))
            });
        assert_eq!((min, max), (DVec2::ZERO, DVec2::splat(8.0)), "{first:?}");
        // Their mean is near the centre: no early bias to one side.
        let mean = first.iter().copied().sum::<DVec2>() / 5.0;
        assert!((mean - DVec2::splat(4.0)).length() < 1.0, "{mean}");
        assert!(spread_order(&[], DVec2::ZERO).is_empty());
    }

    #[test]
    fn batches_fill_the_budget_and_cover_every_view_once() {
        let mut r = Refiner::new(33.0, 512 * 512);
        r.restart(81, false);
        // Unmeasured: one view.
        assert_eq!(r.next_batch(true).unwrap().views, 0..1);
        // 4 ms per view at full size, 5 ms overhead.
        r.measured(1, 1, 4.0, 9.0);
        let b = r.next_batch(true).unwrap();
        assert_eq!(b.views.len(), 7, "(33 − 5) / 4 → 7");
        assert!(!b.clear);
        let mut covered = 1 + b.views.len();
        // Still frames with a cheap overhead: three budgets' worth of views.
        let still = r.next_batch(false).unwrap();
        assert_eq!(still.views, covered..covered + 23, "(99 − 5) / 4 → 23");
        covered = still.views.end;
        // An expensive overhead makes still batches long enough to keep it at 10 % of a
        // frame (here more than the views left).
        r.measured(1, 1, 4.0, 404.0);
        let rest = r.next_batch(false).unwrap();
        assert_eq!(rest.views, covered..81);
        covered = rest.views.end;
        assert_eq!(r.next_batch(false), None);
        assert_eq!(covered, 81);
        assert!(r.converged());
    }

    #[test]
    fn the_cost_model_separates_a_fixed_batch_cost_from_the_cost_per_view() {
        // A batch costs 10 ms plus 2.3 ms per view (lavapipe-like, 512² output).
        let mut r = Refiner::new(33.0, 512 * 512);
        for n in [1usize, 10, 4, 20] {
            r.measured(n, 1, 10.0 + 2.3 * n as f64, 12.0 + 10.0 + 2.3 * n as f64);
        }
        assert!((r.per_view_ms(1).unwrap() - 2.3).abs() < 1e-6);
        assert!((r.frame_overhead_ms() - 22.0).abs() < 1e-6);
        // Still: the overhead rule wants 22·9/2.3 → 87 views: all 81 in one frame.
        r.restart(81, false);
        assert_eq!(r.next_batch(false).unwrap().views, 0..81);
    }

    #[test]
    fn slow_devices_preview_at_a_smaller_size_while_interacting() {
        let mut r = Refiner::new(33.0, 512 * 512);
        r.restart(81, true);
        r.measured(1, 1, 17.0, 20.0); // lavapipe-like: 17 ms per full-size view
        r.restart(81, true);
        assert!(r.divisor() > 1, "preview shrinks");
        let b = r.next_batch(true).unwrap();
        assert!(b.clear && b.views.len() >= PREVIEW_VIEWS, "{b:?}");
        assert!(!r.converged());
        // When the input stops, refinement restarts at full size.
        r.restart(81, false);
        assert_eq!(r.divisor(), 1);
        // A fast device keeps the full size and the whole aperture in one frame.
        let mut fast = Refiner::new(33.0, 512 * 512);
        fast.measured(81, 1, 2.0, 3.0);
        fast.restart(81, true);
        assert_eq!(fast.divisor(), 1);
        assert_eq!(fast.next_batch(true).unwrap().views, 0..81);
    }

    #[test]
    fn a_preview_over_budget_still_spans_the_aperture() {
        let mut r = Refiner::new(33.0, 512 * 512);
        r.restart(81, true);
        assert_eq!(
            r.next_batch(true).unwrap().views,
            0..1,
            "the first frame measures"
        );
        // The frame's fixed cost alone (60 ms) exceeds the 33 ms budget.
        r.measured(1, r.divisor(), 0.5, 60.0);
        r.restart(81, true);
        let first = r.next_batch(true).unwrap();
        assert!(first.clear);
        assert_eq!(first.views.len(), PREVIEW_MIN_VIEWS, "{first:?}");
        // Later batches of the same refinement follow the budget again.
        let next = r.next_batch(true).unwrap();
        assert_eq!(next.views.len(), 1, "{next:?}");
        // A light field with fewer views takes them all.
        r.restart(4, true);
        assert_eq!(r.next_batch(true).unwrap().views, 0..4);
    }

    /// A batch's fixed cost that dwarfs a view's (anti-aliasing's focus test reads every view
    /// whatever the batch) cannot be told apart from batches of one size: the still schedule
    /// doubles its batches until their sizes spread, then sizes them by the fitted line, and
    /// so converges in a handful of frames instead of one view per frame.
    #[test]
    fn a_large_fixed_cost_per_batch_is_measured_and_amortised() {
        let cost = |views: usize| 200.0 + 5.0 * views as f64; // ms: fixed + per view
        let mut r = Refiner::new(33.0, 512 * 512);
        r.restart(81, false);
        let mut frames = 0;
        let mut sizes = Vec::new();
        while let Some(b) = r.next_batch(false) {
            let n = b.views.len();
            sizes.push(n);
            r.measured(n, b.divisor, cost(n), cost(n) + 6.0);
            frames += 1;
            assert!(frames <= 12, "not converging: {sizes:?}");
        }
        assert!(r.converged());
        assert_eq!(sizes.iter().sum::<usize>(), 81);
        assert!(
            sizes[1] >= 2 && sizes[2] > sizes[1],
            "doubling while unmeasured: {sizes:?}"
        );
        // No still frame is planned past the cap, fixed cost included.
        assert!(
            sizes.iter().all(|&n| cost(n) <= MAX_STILL_FRAME_MS + 1e-9),
            "{sizes:?}"
        );
    }

    #[test]
    fn a_full_size_sum_shows_only_once_it_has_a_previews_views() {
        let b = |views: std::ops::Range<usize>, divisor| Batch {
            clear: views.start == 0,
            views,
            divisor,
        };
        assert!(shows_batch(&b(0..1, 4), 81, true), "previews always show");
        assert!(
            !shows_batch(&b(0..1, 1), 81, true),
            "one view at full size stays hidden"
        );
        assert!(!shows_batch(&b(4..8, 1), 81, true));
        assert!(shows_batch(&b(4..9, 1), 81, true));
        assert!(
            shows_batch(&b(0..4, 1), 4, true),
            "a small aperture: all its views"
        );
        assert!(shows_batch(&b(0..1, 1), 81, false), "nothing else to show");
    }
}
