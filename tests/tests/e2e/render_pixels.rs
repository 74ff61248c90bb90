//! `sightline render`: pixel checks on real levels (the eye leaf's colour appears, pictures are
//! never empty, the PVS check paints red exactly when a visible leaf is removed from the PVS).

use std::collections::BTreeMap;

use glam::DVec3;
use sightline_validate::bsp::BspTree;
use sightline_validate::load;
use sightline_validate::pvs::level_pvs;
use sightline_validate::render::image::{ALARM_RED, Image, leaf_colour};
use sightline_validate::render::matrix::render_matrix;
use sightline_validate::render::plan::{self, PlanOptions, render_plan};
use sightline_validate::render::view::{Camera, render_view};

/// The start of E1M1, looking down the first corridor.
const E1M1_EYE: DVec3 = DVec3::new(480.0, -352.0, 110.0);

fn e1m1() -> Option<sightline_formats::Level> {
    let path = sightline_tests::shared_maps()?.join("ericw/e1m1.vis.bsp");
    path.is_file()
        .then(|| load::load_level(&path, &sightline_validate::NoProgress).unwrap_or_else(|e| panic!("{e:#}")))
}

fn distinct_colours(img: &Image) -> usize {
    img.pixels.iter().collect::<std::collections::BTreeSet<_>>().len()
}

/// True when `c` is `base` scaled by one factor (within rounding).
fn is_shade_of(c: [u8; 3], base: [u8; 3]) -> bool {
    let k = f64::from(c[0]) / f64::from(base[0].max(1));
    (0..3).all(|i| (f64::from(base[i]) * k - f64::from(c[i])).abs() <= 2.0) && k > 0.3
}

#[test]
fn first_person_view_shows_the_eye_leaf_and_no_red_on_the_reference_pvs() {
    let Some(level) = e1m1() else { return };
    let tree = BspTree::new(&level).unwrap();
    let mut pvs = level_pvs(&level).unwrap();
    let cam = Camera { eye: E1M1_EYE, yaw: 90.0, pitch: -20.0, fov: 90.0, width: 160, height: 120 };
    let v = render_view(&tree, &cam, Some(&pvs)).unwrap();
    assert!(distinct_colours(&v.image) > 20, "a real view has many shades");
    assert!(v.image.count([0, 0, 0]) < v.image.pixels.len() / 10, "a sealed level shows surfaces everywhere");
    assert_eq!(v.red_pixels, 0);
    assert_eq!(v.image.count(ALARM_RED), 0);
    // Looking down, the eye leaf's own floor is in the picture, in its own colour.
    let eye_colour = leaf_colour(v.eye_leaf);
    let eye_pixels: Vec<[u8; 3]> = v
        .image
        .pixels
        .iter()
        .zip(&v.pixel_leaves)
        .filter(|(_, l)| **l == Some(v.eye_leaf))
        .map(|(c, _)| *c)
        .collect();
    assert!(eye_pixels.len() > 50, "eye leaf shown by {} pixels", eye_pixels.len());
    assert!(
        eye_pixels.iter().all(|&c| is_shade_of(c, eye_colour)),
        "eye leaf pixels are shades of {eye_colour:?}"
    );

    // Remove the most shown leaf (other than the eye's) from the eye's PVS row: it turns red.
    let mut shown: BTreeMap<u32, usize> = BTreeMap::new();
    for l in v.pixel_leaves.iter().flatten().filter(|&&l| l != v.eye_leaf) {
        *shown.entry(*l).or_default() += 1;
    }
    let (&victim, &pixels) = shown.iter().max_by_key(|(l, n)| (**n, std::cmp::Reverse(**l))).unwrap();
    let victim_cluster = tree.cluster(victim as usize).unwrap();
    pvs.clear(v.eye_cluster as usize, victim_cluster as usize);
    let red = render_view(&tree, &cam, Some(&pvs)).unwrap();
    assert!(red.red_pixels >= pixels, "{} red pixels, leaf {victim} showed {pixels}", red.red_pixels);
}

#[test]
fn plan_and_matrix_are_never_empty() {
    let Some(level) = e1m1() else { return };
    let tree = BspTree::new(&level).unwrap();
    let pvs = level_pvs(&level).unwrap();
    let cam = Camera { eye: E1M1_EYE, yaw: 90.0, pitch: 0.0, fov: 90.0, width: 4, height: 3 };
    let opts = PlanOptions {
        from: Some(E1M1_EYE),
        z: (E1M1_EYE.z - 64.0, E1M1_EYE.z + 64.0),
        camera: Some(cam),
        width: 300,
        portals: Vec::new(),
        leak: vec![E1M1_EYE, E1M1_EYE + DVec3::new(0.0, 2000.0, 0.0)],
    };
    let p = render_plan(&tree, Some(&pvs), &opts).unwrap();
    assert!(p.image.count(plan::EYE) > 0, "the eye leaf is drawn");
    assert!(p.image.count(plan::LEAK) > 50, "the leak path is drawn");
    assert!(!p.frustum_leaves.is_empty() && p.frustum_leaves.len() < p.pvs_leaves.len());
    assert!(p.pvs_leaves.iter().all(|&l| pvs.get(
        tree.cluster(tree.leaf_at(E1M1_EYE)).unwrap() as usize,
        tree.cluster(l as usize).unwrap() as usize
    )));
    assert!(distinct_colours(&p.image) > 10);
    let m = render_matrix(&pvs, None, 512);
    assert!(m.width > 256 && m.width <= 512);
    let lit = m.pixels.iter().filter(|&&c| c != [0, 0, 0]).count();
    assert!(lit > m.pixels.len() / 50 && lit < m.pixels.len(), "{lit} lit pixels");
}
