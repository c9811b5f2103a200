//! ROS 2 bags end to end with `gfsvo convert` and `gfsvo run BAG`: a synthetic sequence
//! converted with zstd chunks (the default) plays to the folder's trajectory byte for
//! byte, and its `--mcap` recording is written with zstd chunks; a conversion that fails
//! half-way leaves neither OUT nor OUT.partial, converting onto an existing path names
//! it, and a bag cut short is refused as truncated, naming the file.

mod common;

use common::{binaries, gfsvo, out_dir};
use gfs_synth::{SynthConfig, SynthSequence};
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

const FRAMES: usize = 20;

/// A small synthetic sequence (20 frames, 320x240), rendered once.
fn sequence() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("synth_bags_20");
        if !dir.join("associations.txt").is_file() {
            let config = SynthConfig {
                frames: FRAMES,
                camera: SynthConfig::scaled_camera(320),
                ..SynthConfig::default()
            };
            SynthSequence::new(config).write_tum(&dir, |_| ()).unwrap();
        }
        dir
    })
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn a_converted_zstd_bag_plays_to_the_folders_trajectory() {
    binaries();
    let seq = sequence();
    let dir = out_dir("bags_play");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let bag = dir.join("seq.mcap");
    let o = gfsvo(&["convert", path(seq), path(&bag)]);
    assert!(o.status.success(), "{}", text(&o));
    let bytes = std::fs::read(&bag).unwrap();
    assert!(bytes.windows(4).any(|w| w == b"zstd"), "zstd chunks");
    let config = seq.join("synthetic.toml");
    let run = |dataset: &Path, out: &Path, mcap: bool| {
        let recording = out.join("odom.mcap");
        let mut args = vec!["run", path(dataset), "--config", path(&config)];
        args.extend(["--out", path(out)]);
        if mcap {
            args.extend(["--mcap", path(&recording)]);
        }
        let o = gfsvo(&args);
        assert!(o.status.success(), "{}", text(&o));
        std::fs::read_to_string(out.join("trajectory.txt")).unwrap()
    };
    let folder = run(seq, &dir.join("folder"), false);
    let played = run(&bag, &dir.join("bag"), true);
    assert_eq!(
        folder.lines().filter(|l| !l.starts_with('#')).count(),
        FRAMES
    );
    assert_eq!(played, folder, "the bag plays to the folder's trajectory");
    let recording = std::fs::read(dir.join("bag").join("odom.mcap")).unwrap();
    assert!(recording.windows(4).any(|w| w == b"zstd"), "zstd recording");
    assert!(!dir.join("bag").join("odom.mcap.partial").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn failed_and_clashing_conversions_leave_no_bag_and_name_the_path() {
    binaries();
    let dir = out_dir("bags_convert");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let broken = dir.join("synthetic_broken");
    let status = std::process::Command::new("cp")
        .arg("-r")
        .arg(sequence())
        .arg(&broken)
        .status()
        .unwrap();
    assert!(status.success());
    let assoc = std::fs::read_to_string(broken.join("associations.txt")).unwrap();
    let rgb = assoc
        .lines()
        .filter(|l| !l.starts_with('#'))
        .nth(8)
        .and_then(|l| l.split_whitespace().nth(1))
        .unwrap();
    let image = broken.join(rgb);
    let bytes = std::fs::read(&image).unwrap();
    std::fs::write(&image, &bytes[..bytes.len() / 3]).unwrap();

    for out in [dir.join("folder_bag"), dir.join("bare.mcap")] {
        let o = gfsvo(&["convert", path(&broken), path(&out)]);
        assert!(!o.status.success(), "a broken frame fails the conversion");
        let mut partial = out.clone().into_os_string();
        partial.push(".partial");
        assert!(
            !out.exists() && !Path::new(&partial).exists(),
            "{out:?} left"
        );
    }

    let out = dir.join("good.mcap");
    let o = gfsvo(&["convert", path(sequence()), path(&out)]);
    assert!(o.status.success(), "{}", text(&o));
    let before = std::fs::read(&out).unwrap();
    let o = gfsvo(&["convert", path(sequence()), path(&out)]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains(&format!("{}: exists", out.display())),
        "{}",
        text(&o)
    );
    assert_eq!(std::fs::read(&out).unwrap(), before, "OUT untouched");

    std::fs::write(&out, &before[..before.len() / 2]).unwrap();
    let config = sequence().join("synthetic.toml");
    let run_out = dir.join("cut_run");
    let o = gfsvo(&[
        "run",
        path(&out),
        "--config",
        path(&config),
        "--out",
        path(&run_out),
    ]);
    assert!(!o.status.success());
    let stderr = text(&o);
    assert!(
        stderr.contains(&format!("{}: truncated", out.display())),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
