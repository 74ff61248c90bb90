use glam::Vec3;
use sightline::gvs::Cell;
use sightline::scenegen::{self, Rng};
use sightline_runtime::bvh::Bvh;
fn cpu() -> f64 {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").unwrap();
    let rest = stat.rsplit_once(')').unwrap().1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    (f[11].parse::<f64>().unwrap() + f[12].parse::<f64>().unwrap()) / 100.0
}
fn main() {
    let n: usize = std::env::args().nth(1).unwrap().parse().unwrap();
    let scene = scenegen::city(n, 1);
    let (lo, hi) = scene.cells[0];
    let cell = Cell::new(lo, hi);
    let c0 = cpu();
    let bvh = Bvh::build(&scene.triangles);
    println!("tris {} build cpu {:.2}s", scene.triangles.len(), cpu() - c0);
    let mut rng = Rng::new(3);
    const R: usize = 3_000_000;
    let eye: Vec<(Vec3, Vec3)> = (0..R).map(|_| {
        let o = lo + (hi - lo) * Vec3::new(rng.unit(), rng.unit(), rng.unit());
        let yaw = rng.range(0.0, std::f32::consts::TAU);
        let pitch = rng.range(-0.8, 0.8);
        (o, Vec3::new(pitch.cos() * yaw.cos(), pitch.cos() * yaw.sin(), pitch.sin()))
    }).collect();
    let surface: Vec<(Vec3, Vec3)> = (1..=R as u64).map(|i| cell.sample_ray(i)).collect();
    // Random rays from anywhere above the city into it.
    let b = (scene.triangles.len() as f32).sqrt();
    let _ = b;
    for (name, rays) in [("eye", &eye), ("surface", &surface)] {
        let c0 = cpu(); let t0 = std::time::Instant::now();
        let mut hits = 0;
        for &(o, d) in rays.iter() { hits += bvh.intersect(o, d, f32::INFINITY).is_some() as u32; }
        let c = cpu() - c0;
        println!("{name}: {} rays, hits {hits}, cpu {c:.2}s => {:.2} M rays per cpu-second (wall {:.2}s)", R, R as f64 / c / 1e6, t0.elapsed().as_secs_f64());
    }
}
