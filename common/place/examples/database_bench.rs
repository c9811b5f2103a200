//! Query time of the keyframe database at loop-closure scale (printed, nothing
//! asserted): bag-of-words vectors of rendered frames of several scenes, each added
//! many times under distinct ids so the inverted lists grow as with thousands of
//! keyframes, then queried with other frames. Times are the thread's CPU time.
//! Run with `cargo run --release -p gfs-place --example database_bench`.

use gfs_core::GrayImage;
use gfs_core::descriptor::Descriptor;
use gfs_place::{BowVector, KeyFrameDatabase, Vocabulary};
use gfs_points::{OrbConfig, OrbExtractor, OrbFeatures};
use gfs_synth::{SceneKind, SynthConfig, SynthSequence, TrajectoryKind};

/// CPU time of this thread, milliseconds (the machine may be shared).
fn cpu_ms() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid, writable timespec for the duration of the call.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    if rc != 0 {
        return 0.0;
    }
    t.tv_sec as f64 * 1e3 + t.tv_nsec as f64 * 1e-6
}

fn descriptors(extractor: &mut OrbExtractor, gray: &GrayImage) -> Vec<Descriptor> {
    let mut features = OrbFeatures::default();
    match extractor.extract(gray.view(), None, &mut features) {
        Ok(()) => features.descriptors,
        Err(e) => panic!("extraction without depth cannot fail: {e}"),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let vocabulary = Vocabulary::default_orb();
    let mut extractor = match OrbExtractor::new(OrbConfig::default()) {
        Ok(e) => e,
        Err(e) => panic!("default ORB config: {e}"),
    };
    let mut frames: Vec<BowVector> = Vec::new();
    let mut transform_ms = Vec::new();
    for (n, scene) in SceneKind::ALL.iter().enumerate() {
        let sequence = SynthSequence::new(SynthConfig {
            scene: *scene,
            trajectory: TrajectoryKind::Fast,
            frames: 300,
            seed: 500 + n as u64,
            ..SynthConfig::default()
        });
        for f in (0..300).step_by(10) {
            let d = descriptors(&mut extractor, &sequence.render(f).gray);
            let start = cpu_ms();
            frames.push(vocabulary.transform(&d));
            transform_ms.push(cpu_ms() - start);
        }
    }
    println!(
        "{} rendered frames, transform of ~1000 descriptors: median {:.3} ms",
        frames.len(),
        median(transform_ms)
    );
    for keyframes in [100usize, 1000, 5000] {
        let mut database = KeyFrameDatabase::new(vocabulary.num_words());
        let start = cpu_ms();
        for id in 0..keyframes {
            // Odd frames are the queries, even ones the keyframes.
            database.add(id as u64, &frames[(2 * id) % frames.len()]);
        }
        let add_ms = (cpu_ms() - start) / keyframes as f64;
        let mut query_ms = Vec::new();
        let mut hit_count = 0;
        for q in frames.iter().skip(1).step_by(2) {
            let start = cpu_ms();
            let hits = database.query(q, 3, |id| id % 7 == 0);
            query_ms.push(cpu_ms() - start);
            hit_count += hits.len();
        }
        println!(
            "{keyframes:5} keyframes: add {add_ms:.3} ms each, query median {:.3} ms \
             ({hit_count} results over {} queries)",
            median(query_ms),
            frames.len() / 2
        );
    }
}
