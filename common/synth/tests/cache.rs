//! The sequence cache (its own test binary: it sets XDG_CACHE_HOME for the process).

use gfs_synth::{NoiseConfig, SynthConfig, cached_sequence};
use std::fs;

#[test]
fn cached_sequence_renders_once_into_place_and_then_reuses_it() {
    let root = std::env::temp_dir().join(format!("gfs-synth-cache-{}", std::process::id()));
    let _ = fs::remove_dir_all(&root);
    // SAFETY: this test binary has a single test, so no other thread reads the
    // environment concurrently.
    unsafe { std::env::set_var("XDG_CACHE_HOME", &root) };
    let config = SynthConfig {
        frames: 2,
        camera: SynthConfig::scaled_camera(32),
        noise: NoiseConfig::none(),
        ..SynthConfig::default()
    };
    let mut rendered = 0;
    let dir = cached_sequence(&config, |n| rendered = n).unwrap();
    assert_eq!(rendered, 2);
    assert!(dir.starts_with(root.join("gfsvo")));
    let name = dir.file_name().unwrap().to_string_lossy().into_owned();
    assert!(name.starts_with("synth_room_slow_2_seed1_"), "{name}");
    assert_eq!(fs::read_dir(dir.join("rgb")).unwrap().count(), 2);
    // Nothing else in the cache: the temporary folder was renamed, not copied.
    assert_eq!(fs::read_dir(root.join("gfsvo")).unwrap().count(), 1);

    let mut again = 0;
    assert_eq!(cached_sequence(&config, |n| again = n).unwrap(), dir);
    assert_eq!(again, 0, "a complete cached sequence is not rendered again");
    fs::remove_dir_all(&root).unwrap();
}
