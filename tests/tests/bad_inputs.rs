//! A clear answer to every bad input, before any work where it can be known: nonsense
//! arguments and config values, a garbage ground-truth line, dataset paths and run ids
//! that start with `-`, unreadable images (one policy in every mode: the same
//! trajectory inline and in the pipeline), a run whose frames are all unusable, and
//! SIGINT during an inline run (the outputs hold the frames done, nothing more, and
//! the map so far is saved), and map files that do not fit the run.

mod common;

use common::{assert_nothing_left, binaries, gfsvo, out_dir, run_id};
use gfs_synth::{SynthConfig, SynthSequence};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;

const FRAMES: usize = 40;

/// A small synthetic sequence (40 frames, 320x240), rendered once.
fn small() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("synth_small_40");
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

/// A copy of the small sequence at `dir`, for a test to break.
fn copy_of_small(dir: &Path) -> PathBuf {
    let _ = std::fs::remove_dir_all(dir);
    let status = Command::new("cp")
        .arg("-r")
        .arg(small())
        .arg(dir)
        .status()
        .unwrap();
    assert!(status.success());
    dir.to_path_buf()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn expect_error(o: &Output, needles: &[&str]) {
    let stderr = text(&o.stderr);
    assert!(!o.status.success(), "should fail: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{n:?} not in: {stderr}");
    }
}

#[test]
fn nonsense_arguments_are_refused_naming_the_value() {
    let seq = small().to_str().unwrap();
    let out = out_dir("args");
    let out_s = out.to_str().unwrap();
    expect_error(
        &gfsvo(&["synth", "--width", "100000", "--out", out_s]),
        &["--width 100000", "4096"],
    );
    expect_error(
        &gfsvo(&["--log", "nonsense", "run", seq, "--out", out_s]),
        &["--log \"nonsense\"", "expected a level"],
    );
    for rate in ["0", "nan", "-3"] {
        expect_error(
            &gfsvo(&[
                "run",
                seq,
                "--mode",
                "realtime",
                &format!("--max-rate={rate}"),
                "--out",
                out_s,
            ]),
            &["--max-rate"],
        );
    }
    let file = out_dir("args_file");
    let _ = std::fs::remove_dir_all(&file);
    std::fs::write(&file, "not a folder").unwrap();
    expect_error(
        &gfsvo(&["run", seq, "--out", file.to_str().unwrap()]),
        &[&format!("output folder {}", file.display())],
    );
    let config = out_dir("args_config.toml");
    std::fs::write(
        &config,
        "[camera]\nfx=250.0\nfy=250.0\ncx=160.0\ncy=120.0\nwidth=320\nheight=240\n[depth]\nscale = 0.0\n",
    )
    .unwrap();
    let o = gfsvo(&[
        "run",
        seq,
        "--config",
        config.to_str().unwrap(),
        "--out",
        out_s,
    ]);
    expect_error(&o, &["depth.scale = 0"]);
    let stderr = text(&o.stderr);
    assert!(
        !stderr.contains('\u{1b}'),
        "no colours off a terminal: {stderr:?}"
    );
    assert!(!out.join("trajectory.txt").exists(), "nothing ran");
}

#[test]
fn a_garbage_ground_truth_line_fails_before_any_work() {
    let dir = copy_of_small(&out_dir("gt_garbage_seq"));
    let gt = dir.join("groundtruth.txt");
    let mut lines: Vec<String> = std::fs::read_to_string(&gt)
        .unwrap()
        .lines()
        .map(str::to_owned)
        .collect();
    lines.insert(7, "1000.2 garbage 0 0 0 0 0 1".to_owned());
    std::fs::write(&gt, lines.join("\n")).unwrap();
    let out = out_dir("gt_garbage");
    let _ = std::fs::remove_dir_all(&out);
    let o = gfsvo(&["run", dir.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    expect_error(&o, &["groundtruth.txt", "8"]);
    assert!(!out.join("trajectory.txt").exists(), "no work was done");
}

#[test]
fn dash_leading_dataset_and_run_id_reach_every_stage() {
    let parent = out_dir("dash");
    std::fs::create_dir_all(&parent).unwrap();
    copy_of_small(&parent.join("-seq"));
    let id = format!("-{}", run_id("dash"));
    let o = Command::new(binaries().join("gfsvo"))
        .current_dir(&parent)
        .args(["run", "--frames", "10", "--out", "out", "--json"])
        .arg(format!("--run-id={id}"))
        .args(["--", "-seq"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    let lines = std::fs::read_to_string(parent.join("out/trajectory.txt")).unwrap();
    assert_eq!(lines.lines().filter(|l| !l.starts_with('#')).count(), 10);
    assert_nothing_left(&id);
}

/// Breaks frames 5 (truncated colour), 12 (empty depth), 20 (missing colour) and 27
/// (colour cut to a few bytes) of a copy of the small sequence.
fn broken_sequence() -> PathBuf {
    let dir = copy_of_small(&out_dir("broken_seq"));
    let assoc = std::fs::read_to_string(dir.join("associations.txt")).unwrap();
    let rows: Vec<Vec<&str>> = assoc
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split_whitespace().collect())
        .collect();
    let rgb = |i: usize| dir.join(rows[i][1]);
    let depth = |i: usize| dir.join(rows[i][3]);
    let cut = |path: PathBuf, n: usize| {
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..n.min(bytes.len())]).unwrap();
    };
    cut(rgb(5), 300);
    cut(depth(12), 0);
    std::fs::remove_file(rgb(20)).unwrap();
    cut(rgb(27), 40);
    dir
}

#[test]
fn unreadable_frames_give_the_same_trajectory_in_every_mode() {
    let dir = broken_sequence();
    let trajectory = |mode: &str| {
        let (id, out) = (
            run_id(&format!("brk{}", &mode[..3])),
            out_dir(&format!("broken_{mode}")),
        );
        let _ = std::fs::remove_dir_all(&out);
        let o = gfsvo(&[
            "run",
            dir.to_str().unwrap(),
            "--mode",
            mode,
            "--run-id",
            &id,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{mode}: {}", text(&o.stderr));
        assert_nothing_left(&id);
        let status = std::fs::read_to_string(out.join("status.txt")).unwrap();
        let predicted: Vec<usize> = status
            .lines()
            .filter(|l| l.ends_with("predicted"))
            .filter_map(|l| l.split_whitespace().next()?.parse().ok())
            .collect();
        assert_eq!(predicted, [5, 12, 20, 27], "{mode}");
        std::fs::read_to_string(out.join("trajectory.txt")).unwrap()
    };
    let inline = trajectory("inline");
    assert_eq!(
        inline.lines().filter(|l| !l.starts_with('#')).count(),
        FRAMES
    );
    assert_eq!(trajectory("lockstep"), inline);
}

#[test]
fn a_run_with_no_usable_frame_fails_and_says_why() {
    let dir = copy_of_small(&out_dir("unusable_seq"));
    for entry in std::fs::read_dir(dir.join("rgb")).unwrap().flatten() {
        std::fs::write(entry.path(), b"").unwrap();
    }
    for mode in ["inline", "lockstep"] {
        let out = out_dir(&format!("unusable_{mode}"));
        let _ = std::fs::remove_dir_all(&out);
        let o = gfsvo(&[
            "run",
            dir.to_str().unwrap(),
            "--frames",
            "8",
            "--mode",
            mode,
            "--out",
            out.to_str().unwrap(),
        ]);
        expect_error(&o, &["no frame of 8 was tracked"]);
        assert!(
            !text(&o.stdout).contains("ATE"),
            "{mode}: no ATE of guesses"
        );
    }
}

#[test]
fn sigint_during_an_inline_run_writes_only_the_frames_done() {
    let out = out_dir("sigint_inline");
    let _ = std::fs::remove_dir_all(&out);
    let map = out_dir("sigint_inline.gfsmap");
    let _ = std::fs::remove_file(&map);
    let mut child = Command::new(binaries().join("gfsvo"))
        .args([
            "--log",
            "gfs_odometry=debug",
            "run",
            "--mode",
            "inline",
            "--out",
        ])
        .arg(&out)
        .arg("--save-map")
        .arg(&map)
        .arg(common::sequence())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for the odometry's debug lines of a few frames, then interrupt.
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut seen = 0;
    let mut line = String::new();
    while seen < 10 && stderr.read_line(&mut line).unwrap() > 0 {
        seen += usize::from(line.contains("DEBUG"));
        line.clear();
    }
    let pid = i32::try_from(child.id()).unwrap();
    // SAFETY: kill(2) has no memory effects.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
    let mut rest = String::new();
    let _ = std::io::Read::read_to_string(&mut stderr, &mut rest);
    let status = child.wait().unwrap();
    assert!(!status.success());
    assert!(rest.contains("interrupted after"), "{rest}");
    let trajectory = std::fs::read_to_string(out.join("trajectory.txt")).unwrap();
    let poses = trajectory.lines().filter(|l| !l.starts_with('#')).count();
    assert!(
        poses > 0 && poses < common::FRAMES,
        "{poses} poses after SIGINT"
    );
    map_files_are_used_or_refused_naming_them(&map);
}

/// The map an interrupted run saved localises a run on its sequence; on a sequence of
/// another camera, or cut short, it is refused with an error naming it.
fn map_files_are_used_or_refused_naming_them(map: &Path) {
    let name = map.display().to_string();
    let localise = |dataset: &Path, map: &Path| {
        let out = out_dir("map_file_localise");
        let _ = std::fs::remove_dir_all(&out);
        Command::new(binaries().join("gfsvo"))
            .args([
                "run",
                "--mode",
                "inline",
                "--json",
                "--frames",
                "10",
                "--localize",
            ])
            .arg("--load-map")
            .arg(map)
            .arg("--out")
            .arg(&out)
            .arg(dataset)
            .output()
            .unwrap()
    };
    let o = localise(common::sequence(), map);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["keyframes_added"], 0, "{json}");
    assert_eq!(
        json["status"]["predicted"],
        serde_json::Value::Null,
        "{json}"
    );
    expect_error(&localise(small(), map), &[&name, "another camera"]);
    let bytes = std::fs::read(map).unwrap();
    std::fs::write(map, &bytes[..bytes.len() - 100]).unwrap();
    expect_error(&localise(common::sequence(), map), &[&name, "truncated"]);
}

/// `gfsvo run --json` carries the NEES of the published covariances, `gfsvo eval
/// --consistency` gives the same from the run's files, and a broken covariance file is
/// named with its line.
#[test]
fn the_consistency_of_a_run_is_read_back_and_a_bad_covariance_line_is_named() {
    let out = out_dir("consistency");
    let _ = std::fs::remove_dir_all(&out);
    let o = gfsvo(&[
        "run",
        small().to_str().unwrap(),
        "--mode",
        "inline",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let run: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let nees = &run["nees"];
    assert_eq!(nees["pairs"], FRAMES - 1);
    let mean = nees["mean"].as_f64().expect("a mean NEES");
    // The idealised sensor's textured room: a covariance of the right size, cautious
    // (1.37 over the 300-frame built-in room).
    assert!((0.5..20.0).contains(&mean), "mean NEES {mean}");
    let gt = small().join("groundtruth.txt");
    let est = out.join("odometry.txt");
    let args = |extra: &[&str]| {
        let mut a = vec![
            "eval",
            "--gt",
            gt.to_str().unwrap(),
            "--est",
            est.to_str().unwrap(),
            "--json",
        ];
        a.extend_from_slice(extra);
        gfsvo(&a)
    };
    let o = args(&["--consistency"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let eval: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let again = eval["nees"]["mean"].as_f64().expect("a mean NEES");
    // The files hold the poses to the micrometre.
    assert!((again - mean).abs() < 0.02 * mean, "{again} against {mean}");

    let covariances = out.join("covariance.txt");
    let text_in = std::fs::read_to_string(&covariances).unwrap();
    let mut lines: Vec<String> = text_in.lines().map(str::to_owned).collect();
    lines[4] = lines[4].replacen(' ', " nan-ish ", 1);
    let broken = out.join("broken.txt");
    std::fs::write(&broken, lines.join("\n")).unwrap();
    expect_error(
        &args(&["--consistency", broken.to_str().unwrap()]),
        &["broken.txt", ":5"],
    );
}
