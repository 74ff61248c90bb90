//! Random rays: the cell's quasi-random rays (the thesis' "first" batch, sorted by direction,
//! and the stock "last" strategy), and the main loop that drains the ABS seed queue between them.

use glam::Vec3;

use crate::geom::Halton5;

use super::{Class, Gvs};

impl Gvs<'_> {
    /// Run until termination: drain the queue, then random rays, checking the window.
    pub(crate) fn run(&mut self) {
        // The Halton index starts at the seed (any `u64`, so it wraps past the end).
        let mut halton = Halton5::new(self.p.seed.max(1));
        // "first": all the initial random rays before any ABS.
        // They are cast in order of direction (a fixed, stable order): coherent rays traverse the
        // BVH about twice as fast as scattered ones.
        let first = self.p.first.min(self.p.max_random).min(self.p.max_rays);
        if first > 0 {
            let batch: Vec<(Vec3, Vec3)> =
                (0..first).map(|_| self.cell.ray_at(halton.next_point())).collect();
            // A counting sort on 16³ direction bins: stable, linear.
            let bin = |d: Vec3| {
                let q = |x: f32| ((x + 1.0) * 8.0).clamp(0.0, 15.0) as usize;
                (q(d.z) << 8) | (q(d.y) << 4) | q(d.x)
            };
            let mut start = vec![0usize; 4097];
            for (_, d) in &batch {
                start[bin(*d) + 1] += 1;
            }
            for k in 1..start.len() {
                start[k] += start[k - 1];
            }
            // Scattered into place, then read in order (reading the batch through an index
            // missed the cache on every ray).
            let mut sorted = vec![(Vec3::ZERO, Vec3::ZERO); batch.len()];
            for &(o, d) in &batch {
                let b = bin(d);
                sorted[start[b]] = (o, d);
                start[b] += 1;
            }
            for (o, d) in sorted {
                self.handle(o, d, Class::Random);
            }
        }
        loop {
            while let Some(seed) = self.queue.pop_front() {
                if self.out_of_rays() {
                    self.queue.clear();
                    break;
                }
                self.abs(seed);
            }
            if self.out_of_rays() || self.stats.random >= self.p.max_random {
                break;
            }
            if self.stats.rays - self.window_start >= self.p.window {
                if self.window_new < self.p.min_new {
                    break;
                }
                self.window_start = self.stats.rays;
                self.window_new = 0;
            }
            let (o, d) = self.cell.ray_at(halton.next_point());
            self.handle(o, d, Class::Random);
        }
        if self.p.targets > 0 && !self.out_of_rays() {
            self.sample_targets();
            while let Some(seed) = self.queue.pop_front() {
                if self.out_of_rays() {
                    self.queue.clear();
                    break;
                }
                self.abs(seed);
            }
        }
        self.stats.capped = self.out_of_rays();
    }
}
