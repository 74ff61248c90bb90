//! The error metric over many cells and variants at once: the same ID buffers ([`error`]) compared
//! with every variant's PVS, per triangle and per object, cast in batches of bounded memory.
//!
//! [`Metric::measure`] draws the views of every measured cell, casts their ID buffers in batches
//! of at most a pixel budget ([`PIXEL_BUDGET`] by default), compares each buffer with every row's
//! PVS of the cell and drops the batch, so memory does not grow with the number of views. Only
//! the casting is timed (wall clock, and process CPU time through a clock the caller provides).

use std::time::Instant;

use rayon::prelude::*;

use sightline_job::cancel::{Cancel, Cancelled};
use sightline_job::progress::phase;

use crate::error::{self, ErrorStats, IdBuffer, View};
use crate::geom::Cell;
use crate::sampler::Pvs;
use crate::twins::Twins;
use crate::{Progress, SceneIndex};

/// ID-buffer pixels cast before they are compared with the PVSs and dropped: the error metric
/// holds at most this many (64 MiB of ids; or one buffer, if larger), whatever the number of views
/// and measured cells. A batch is timed as a whole, so it is 16 views of 1000².
pub const PIXEL_BUDGET: usize = 16 << 20;

/// The views of the error metric: how many per measured cell, and their ID buffers' size and
/// field of view (see [`error::views`] and [`error::id_buffer`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewOptions {
    /// Views per measured cell (0 measures nothing).
    pub views: usize,
    /// ID buffer width and height in pixels (0 measures nothing).
    pub res: usize,
    /// ID buffer field of view in degrees, in both directions.
    pub fov: f32,
}

/// A clock of the CPU seconds the process has used; `None` where it cannot be read.
pub type CpuClock = fn() -> Option<f64>;

/// One measured view, as [`Metric::measure`] hands it to its caller (for listings such as the
/// triangles with most wrong pixels, [`error::missed`]).
#[derive(Debug, Clone, Copy)]
pub struct MeasuredView<'a> {
    /// Index of the view's cell in the `cells` measured.
    pub cell: usize,
    /// Index of the view among the cell's views.
    pub view_index: usize,
    /// The view.
    pub view: &'a View,
    /// Its ID buffer.
    pub buffer: &'a IdBuffer,
    /// The first row's PVS of the cell as a bitset ([`Pvs::bitset`]).
    pub first_pvs: &'a [u64],
}

/// The thesis' error metric over the measured cells, and the cost of its ID buffers.
#[derive(Debug)]
pub struct Metric<'a> {
    index: &'a SceneIndex<'a>,
    twins: &'a Twins,
    options: ViewOptions,
    /// Indices of the measured cells.
    measured: &'a [usize],
    /// ID-buffer pixels cast before they are compared and dropped ([`PIXEL_BUDGET`]).
    budget: usize,
    /// The process CPU clock (`None`: CPU time is not measured).
    cpu_clock: Option<CpuClock>,
    /// ID-buffer rays cast so far, their wall-clock seconds and process CPU seconds (`None` where
    /// the CPU clock cannot be read).
    rays: u64,
    seconds: f64,
    cpu: Option<f64>,
}

impl<'a> Metric<'a> {
    /// The metric of the scene `index` (with its `twins`, see [`Twins`]) over the cells whose
    /// indices are `measured`, with `budget` pixels per batch (at least one buffer is cast per
    /// batch, whatever the budget). The CPU seconds of the casting are not measured until
    /// [`Metric::with_cpu_clock`] gives a clock.
    pub fn new(
        index: &'a SceneIndex<'a>,
        twins: &'a Twins,
        options: ViewOptions,
        measured: &'a [usize],
        budget: usize,
    ) -> Self {
        Metric { index, twins, options, measured, budget, cpu_clock: None, rays: 0, seconds: 0.0, cpu: None }
    }

    /// Measure the process CPU seconds of the casting with `clock`.
    pub fn with_cpu_clock(self, clock: CpuClock) -> Self {
        Metric { cpu_clock: Some(clock), cpu: Some(0.0), ..self }
    }

    /// ID-buffer rays (pixels) cast so far.
    pub fn rays(&self) -> u64 {
        self.rays
    }

    /// Wall-clock seconds spent casting ID buffers so far.
    pub fn seconds(&self) -> f64 {
        self.seconds
    }

    /// Process CPU seconds spent casting ID buffers so far; `None` without a CPU clock, or when
    /// it could not be read.
    pub fn cpu_seconds(&self) -> Option<f64> {
        self.cpu
    }

    /// Wrong pixels per view of each of `rows` (a PVS per cell of `cells`), per triangle and per
    /// object (the second stays empty without a component table), over the views of each
    /// measured cell (cell `i`'s views drawn with seed `seed + i`). Buffers are cast in batches of
    /// at most the budget's pixels (at least one buffer), compared with every row and dropped, so
    /// memory does not grow with the number of views. Only the casting is timed.
    ///
    /// `progress` gets a phase `"error"` with a step per measured cell; `cancel` stops the
    /// measure between batches of views. `on_view`, when given, is called with every view whose
    /// cell has a PVS in the first row, in order.
    pub fn measure(
        &mut self,
        cells: &[Cell],
        seed: u64,
        rows: &[&[Pvs]],
        job: (&dyn Progress, &Cancel),
        mut on_view: Option<&mut dyn FnMut(MeasuredView<'_>)>,
    ) -> Result<Vec<[ErrorStats; 2]>, Cancelled> {
        let (progress, cancel) = job;
        let ViewOptions { views, res, fov } = self.options;
        let mut stats = vec![[ErrorStats::default(); 2]; rows.len()];
        if views == 0 || res == 0 {
            return Ok(stats);
        }
        let (tris, comps) = (self.index.tris, &self.index.components);
        let n = tris.len();
        let batch = (self.budget / (res * res)).max(1);
        let cpu_now = || self.cpu_clock.and_then(|c| c());
        let phase = phase(progress, "error", self.measured.len() as u64);
        for &i in self.measured {
            let Some(cell) = cells.get(i) else {
                continue;
            };
            // Every row's PVS of this cell as bitsets: its triangles, and the triangles of the
            // components it reaches (`None`: not measured).
            let bits: Vec<[Option<Vec<u64>>; 2]> = rows
                .iter()
                .map(|pvs| match pvs.get(i) {
                    Some(p) => [
                        Some(p.bitset(n)),
                        (!comps.is_empty()).then(|| comps.covered(n, p.entries.iter().map(|e| e.tri))),
                    ],
                    None => [None, None],
                })
                .collect();
            let views = error::views(cell, views, seed.wrapping_add(i as u64));
            for (b, chunk) in views.chunks(batch).enumerate() {
                cancel.check()?;
                let (t0, cpu0) = (Instant::now(), cpu_now());
                let buffers: Vec<IdBuffer> = chunk
                    .iter()
                    .map(|view| error::id_buffer(&self.index.bvh, tris, self.twins, view, res, fov))
                    .collect();
                self.seconds += t0.elapsed().as_secs_f64();
                let cpu1 = cpu_now();
                self.cpu = self.cpu.zip(cpu1.zip(cpu0)).map(|(c, (b, a))| c + b - a);
                self.rays += (chunk.len() * res * res) as u64;
                for (k, buf) in buffers.iter().enumerate() {
                    let wrong: Vec<[Option<u64>; 2]> = bits
                        .par_iter()
                        .map(|b| b.each_ref().map(|w| w.as_deref().map(|w| error::error_pixels(buf, w))))
                        .collect();
                    for (s, w) in stats.iter_mut().zip(wrong) {
                        for (s, w) in s.iter_mut().zip(w) {
                            if let Some(w) = w {
                                s.add(w);
                            }
                        }
                    }
                    if let (Some(f), Some([Some(first), _]), Some(view)) =
                        (on_view.as_mut(), bits.first(), chunk.get(k))
                    {
                        f(MeasuredView {
                            cell: i,
                            view_index: b * batch + k,
                            view,
                            buffer: buf,
                            first_pvs: first,
                        });
                    }
                }
            }
            phase.advance(1);
        }
        Ok(stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Cancel, NoProgress, Params, Variant, run_cells, scenegen};

    #[test]
    fn the_error_metric_is_the_same_cast_one_buffer_at_a_time_or_all_at_once() {
        let scene = scenegen::spheres(60, false, 2);
        let index = SceneIndex::build(&scene.triangles);
        let twins = Twins::build(&scene.triangles, &index.bvh);
        let cells: Vec<Cell> = scene.cells[..2].iter().map(|&(lo, hi)| Cell::new(lo, hi)).collect();
        let cells = &cells[..];
        let options = ViewOptions { views: 3, res: 64, fov: 60.0 };
        let pvs: Vec<Vec<Pvs>> = [Variant::EdgePoint, Variant::ProbeFirstTarget]
            .map(|v| {
                run_cells(&index, cells, v.params(Params::default()), &NoProgress, &Cancel::new())
                    .expect("not cancelled")
            })
            .into();
        let rows: Vec<&[Pvs]> = pvs.iter().map(Vec::as_slice).collect();
        let measured = [0, 1];
        // One buffer per batch, and every buffer in one batch.
        let mut one = Metric::new(&index, &twins, options, &measured, 1);
        let mut all = Metric::new(&index, &twins, options, &measured, usize::MAX);
        let got = one.measure(cells, 5, &rows, (&NoProgress, &Cancel::new()), None).expect("not cancelled");
        assert_eq!(
            got,
            all.measure(cells, 5, &rows, (&NoProgress, &Cancel::new()), None).expect("not cancelled")
        );
        assert_eq!((one.rays(), all.rays()), (2 * 3 * 64 * 64, 2 * 3 * 64 * 64));
        // The edge-point walk alone leaves wrong pixels here, so the comparison counts something.
        assert!(got[0][0].get().is_some_and(|(mean, _)| mean > 0.0), "{got:?}");
        // Against the definition: every view's buffer counted directly.
        for (r, p) in pvs.iter().enumerate() {
            let mut want = ErrorStats::default();
            for (c, cell) in cells.iter().enumerate() {
                let bits = p[c].bitset(scene.triangles.len());
                for view in error::views(cell, 3, 5 + c as u64) {
                    let buf = error::id_buffer(&index.bvh, &scene.triangles, &twins, &view, 64, options.fov);
                    want.add(error::error_pixels(&buf, &bits));
                }
            }
            assert_eq!(got[r][0], want, "row {r}");
            assert!(got[r][1].get().is_some(), "row {r}: the per-object error is measured");
        }
    }

    #[test]
    fn every_view_of_the_first_row_is_handed_over_in_order() {
        let scene = scenegen::spheres(20, false, 4);
        let index = SceneIndex::build(&scene.triangles);
        let twins = Twins::build(&scene.triangles, &index.bvh);
        let cells: Vec<Cell> = scene.cells[..2].iter().map(|&(lo, hi)| Cell::new(lo, hi)).collect();
        let pvs = run_cells(
            &index,
            &cells,
            Variant::EdgePoint.params(Params::default()),
            &NoProgress,
            &Cancel::new(),
        )
        .expect("not cancelled");
        let options = ViewOptions { views: 3, res: 16, fov: 60.0 };
        let measured = [1, 0];
        // Two buffers per batch: the view index runs on across batches.
        let mut metric = Metric::new(&index, &twins, options, &measured, 2 * 16 * 16);
        let mut seen = Vec::new();
        let mut record = |m: MeasuredView<'_>| {
            assert_eq!(m.buffer.ids.len(), 16 * 16);
            assert_eq!(m.first_pvs, pvs[m.cell].bitset(scene.triangles.len()));
            seen.push((m.cell, m.view_index));
        };
        metric
            .measure(&cells, 1, &[&pvs], (&NoProgress, &Cancel::new()), Some(&mut record))
            .expect("not cancelled");
        assert_eq!(seen, [(1, 0), (1, 1), (1, 2), (0, 0), (0, 1), (0, 2)]);
        assert_eq!(metric.cpu_seconds(), None);
    }
}
