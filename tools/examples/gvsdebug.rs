use glam::Vec3;
use sightline::gvs::{self, error, Cell, Params, Variant};
use sightline::scenegen;
use sightline_runtime::bvh::Bvh;
use std::collections::HashMap;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: u32 = args[1].parse().unwrap();
    let v = match args[2].as_str() { "gvs" => Variant::Stock, "edgepoint" => Variant::EdgePoint, _ => Variant::Depth4 };
    let s = scenegen::generate(scenegen::Kind::Spheres, n, 1);
    let bvh = Bvh::build(&s.triangles);
    let cell = Cell::new(s.cells[0].0, s.cells[0].1);
    let mut p = v.params(Params::default()); p.silhouette = args.len() > 3;
    let pvs = gvs::sampler::run(&s.triangles, &bvh, cell, p);
    let bits = pvs.bitset(s.triangles.len());
    println!("pvs {} rays {:?}", pvs.entries.len(), pvs.stats);
    let views = error::views(&cell, 10, 1);
    let mut missed: HashMap<u32, u32> = HashMap::new();
    for vw in &views {
        let ids = error::id_buffer(&bvh, vw, 1000, 60.0);
        println!("view err {}", error::error_pixels(&ids, &bits));
        for &t in &ids { if t != u32::MAX && bits[t as usize/64] & (1<<(t%64)) == 0 { *missed.entry(t).or_default() += 1; } }
    }
    let mut m: Vec<_> = missed.into_iter().collect();
    m.sort_by_key(|x| std::cmp::Reverse(x.1));
    println!("missed tris {}", m.len());
    let c = cell.centre();
    for &(t, px) in m.iter().take(30) {
        let tri = s.triangles[t as usize];
        let cen = (tri[0]+tri[1]+tri[2])/3.0;
        let d = (cen - c).length();
        let area = (tri[1]-tri[0]).cross(tri[2]-tri[0]).length()*0.5;
        // neighbours in PVS? sphere index = t/80
        let sph = t/80;
        let n_in = (sph*80..sph*80+80).filter(|&k| bits[k as usize/64] & (1<<(k%64)) != 0).count();
        println!("tri {t} px {px} dist {d:.1} area {area:.3} sphere {sph} sphere tris in pvs {n_in}");
    }
}
