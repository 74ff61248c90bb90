//! The one stop request (`sightline_job::cancel::Cancel`) is honoured by every long-running
//! library: compile in each of its phases, vis at a batch boundary, validation between leaves,
//! GVS between cells. A receiver of progress cancels when a chosen phase begins (as a Ctrl-C
//! handler would at that moment); the run must end with its "cancelled" error, not a result.

use std::sync::Mutex;

use sightline_compiler::vis::VisOptions;
use sightline_compiler::{CompileError, CompileOptions, Source, compile};
use sightline_job::cancel::Cancel;
use sightline_job::progress::{NoProgress, Progress};

/// Cancels `cancel` when phase `at` begins, and records the phases it saw.
struct CancelAt {
    at: &'static str,
    cancel: Cancel,
    seen: Mutex<Vec<String>>,
}

impl CancelAt {
    fn new(at: &'static str, cancel: &Cancel) -> Self {
        Self { at, cancel: cancel.clone(), seen: Mutex::new(Vec::new()) }
    }

    fn seen(&self) -> Vec<String> {
        self.seen.lock().expect("phases").clone()
    }
}

impl Progress for CancelAt {
    fn begin(&self, phase: &str, _: u64) {
        self.seen.lock().expect("phases").push(phase.to_string());
        if phase == self.at {
            self.cancel.cancel();
        }
    }
    fn advance(&self, _: u64) {}
    fn end(&self) {}
}

fn stairs() -> Source {
    let path = sightline_tests::bundled_maps().join("stairs_pillars.map");
    Source::read(&path).expect("bundled map")
}

#[test]
fn compile_stops_in_the_phase_it_is_cancelled_in() {
    for phase in ["csg", "bsp", "portals", "outside", "emit"] {
        let cancel = Cancel::new();
        let opts =
            CompileOptions { cancel: cancel.clone(), vis: Some(VisOptions::default()), ..Default::default() };
        let progress = CancelAt::new(phase, &cancel);
        match compile(&stairs(), &opts, &progress) {
            Err(CompileError::Cancelled { phase: stopped }) => assert_eq!(stopped, phase),
            other => panic!("cancelled in {phase}: {:?}", other.map(|c| c.stats.phases)),
        }
        let seen = progress.seen();
        assert_eq!(seen.last().map(String::as_str), Some(phase), "no phase after {phase} began: {seen:?}");
    }
}

#[test]
fn a_mesh_compile_stops_in_the_phase_it_is_cancelled_in() {
    use sightline_tests::coplanar::{Floor, room_obj};
    let obj = room_obj(Floor::Shuffled(3), 2000);
    let tri = sightline_formats::obj::load_from_bytes(obj.as_bytes(), "room.obj").expect("loads");
    let source = Source::Mesh { mesh: (&tri).into(), file: "room.obj".into() };
    for phase in ["csg", "bsp", "portals", "outside", "emit"] {
        let cancel = Cancel::new();
        let opts =
            CompileOptions { cancel: cancel.clone(), vis: Some(VisOptions::default()), ..Default::default() };
        let progress = CancelAt::new(phase, &cancel);
        match compile(&source, &opts, &progress) {
            Err(CompileError::Cancelled { phase: stopped }) => assert_eq!(stopped, phase),
            other => panic!("cancelled in {phase}: {:?}", other.map(|c| c.stats.phases)),
        }
        let seen = progress.seen();
        assert_eq!(seen.last().map(String::as_str), Some(phase), "no phase after {phase} began: {seen:?}");
    }
}

#[test]
fn compile_stops_vis_at_its_first_batch_boundary() {
    let cancel = Cancel::new();
    let opts =
        CompileOptions { cancel: cancel.clone(), vis: Some(VisOptions::default()), ..Default::default() };
    let progress = CancelAt::new("vis flow", &cancel);
    match compile(&stairs(), &opts, &progress) {
        Err(CompileError::Vis(sightline_compiler::vis::VisError::Interrupted { done, total })) => {
            assert!(done < total, "{done} of {total}")
        }
        other => panic!("expected an interrupted vis: {:?}", other.map(|c| c.stats.phases)),
    }
    // Uncancelled, the same compile finishes.
    let done = compile(
        &stairs(),
        &CompileOptions { vis: Some(VisOptions::default()), ..Default::default() },
        &NoProgress,
    );
    assert!(done.is_ok());
}

#[test]
fn validation_stops_when_cancelled() {
    let compiled = compile(
        &stairs(),
        &CompileOptions { vis: Some(VisOptions::default()), ..Default::default() },
        &NoProgress,
    )
    .expect("compiles");
    let pvs = sightline_validate::pvs::level_pvs(&compiled.level).expect("pvs");
    let cancel = Cancel::new();
    let opts = sightline_validate::Options { rays: 200_000, cancel: cancel.clone(), ..Default::default() };
    let progress = CancelAt::new("tree", &cancel);
    let r = sightline_validate::validate(&compiled.level, &pvs, &opts, &progress);
    assert!(matches!(r, Err(sightline_validate::ValidateError::Cancelled)), "{r:?}");
    let opts = sightline_validate::Options { rays: 200_000, ..Default::default() };
    assert!(sightline_validate::validate(&compiled.level, &pvs, &opts, &NoProgress).is_ok());
}

#[test]
fn gvs_stops_when_cancelled() {
    use sightline_gvs::{Cell, Params, SceneIndex, Variant, scenegen};
    let scene = scenegen::spheres(20, true, 3);
    let index = SceneIndex::build(&scene.triangles);
    let cells: Vec<Cell> = (0..3)
        .map(|i| Cell::new(glam::Vec3::splat(18.0 + i as f32), glam::Vec3::splat(19.0 + i as f32)))
        .collect();
    let params = Params { window: 2_000, first: 1_000, ..Params::default() };
    let cancel = Cancel::new();
    let variant = Variant::EdgePoint;
    let progress = CancelAt::new(variant.name(), &cancel);
    let r = sightline_gvs::run_variant(&index, &cells, variant, params, &progress, &cancel);
    assert!(r.is_err(), "a cancelled run returns no face sets");
    let r = sightline_gvs::run_variant(&index, &cells, variant, params, &NoProgress, &Cancel::new());
    assert_eq!(r.map(|p| p.len()).ok(), Some(cells.len()));
}
