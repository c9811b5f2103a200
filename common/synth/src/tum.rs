//! Writing a sequence in TUM RGB-D layout, and the cache of generated sequences.
//!
//! Layout: `rgb/<stamp>.png` (8-bit colour), `depth/<stamp>.png` (16-bit, 5000 units per
//! metre, 0 = missing), `rgb.txt`, `depth.txt`, `associations.txt`, `groundtruth.txt`
//! (`stamp tx ty tz qx qy qz qw`, `T_wc`), and `synthetic.toml`, the camera and depth
//! tables of the sequence (its presence tells `gfsvo` which camera config to use).

use crate::error::{SynthError, io};
use crate::noise::DEPTH_SCALE;
use crate::render::RenderBuffers;
use crate::sensor::DepthModel;
use crate::sequence::{SynthConfig, SynthFrame, SynthSequence};
use gfs_core::{DepthImage, GrayImage, RgbImage};
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use std::fmt::Write as _;
use std::fs;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::mpsc;

/// Bump when the renderer's output changes, so that cached sequences are re-rendered.
const RENDER_REVISION: u32 = 1;

/// A rendered frame on its way to the PNG writer.
struct Encoded {
    stamp: String,
    rgb: Vec<u8>,
    depth: Vec<u16>,
}

impl SynthSequence {
    /// Renders every frame and writes the sequence into `dir` in TUM RGB-D layout
    /// (created if needed; files of the same names are overwritten). `progress` is
    /// called with the number of frames rendered so far. PNG encoding runs on its own
    /// thread, overlapped with rendering.
    ///
    /// # Errors
    /// [`SynthError::Io`] / [`SynthError::Encode`] naming the file that could not be
    /// written; [`SynthError::WriterStopped`] if the writer thread died.
    pub fn write_tum(&self, dir: &Path, mut progress: impl FnMut(usize)) -> Result<(), SynthError> {
        for sub in ["rgb", "depth"] {
            let path = dir.join(sub);
            fs::create_dir_all(&path).map_err(io(path))?;
        }
        let (w, h) = (
            self.config().camera.width as u32,
            self.config().camera.height as u32,
        );
        let stamps: Vec<String> = (0..self.len())
            .map(|i| self.timestamp(i).to_string())
            .collect();
        let frames = self.len();
        let (sender, receiver) = mpsc::sync_channel::<Encoded>(2);
        std::thread::scope(|scope| {
            let writer = scope.spawn(move || -> Result<usize, SynthError> {
                let mut written = 0;
                for frame in receiver {
                    let rgb_path = dir.join("rgb").join(format!("{}.png", frame.stamp));
                    write_png(&rgb_path, &frame.rgb, w, h, ExtendedColorType::Rgb8)?;
                    let depth_path = dir.join("depth").join(format!("{}.png", frame.stamp));
                    let bytes: Vec<u8> = frame.depth.iter().flat_map(|v| v.to_ne_bytes()).collect();
                    write_png(&depth_path, &bytes, w, h, ExtendedColorType::L16)?;
                    written += 1;
                }
                Ok(written)
            });
            let mut scratch = RenderBuffers::default();
            let mut frame = SynthFrame {
                index: 0,
                timestamp: Default::default(),
                pose: nalgebra::Isometry3::identity(),
                rgb: RgbImage::new(0, 0),
                gray: GrayImage::new(0, 0),
                depth: DepthImage::new(0, 0),
            };
            for (i, stamp) in stamps.iter().enumerate() {
                self.render_into(i, &mut scratch, &mut frame);
                let message = Encoded {
                    stamp: stamp.clone(),
                    rgb: frame.rgb.as_slice().iter().flatten().copied().collect(),
                    depth: frame
                        .depth
                        .as_slice()
                        .iter()
                        .map(|&z| depth_units(z))
                        .collect(),
                };
                if sender.send(message).is_err() {
                    break; // the writer failed: its error is reported below
                }
                progress(i + 1);
            }
            drop(sender);
            match writer.join() {
                Ok(Ok(written)) if written == frames => Ok(()),
                Ok(Ok(written)) => Err(SynthError::WriterStopped { written, frames }),
                Ok(Err(e)) => Err(e),
                Err(_) => Err(SynthError::WriterStopped { written: 0, frames }),
            }
        })?;
        self.write_lists(dir, &stamps)
    }

    /// `rgb.txt`, `depth.txt`, `associations.txt`, `groundtruth.txt`, `synthetic.toml`.
    fn write_lists(&self, dir: &Path, stamps: &[String]) -> Result<(), SynthError> {
        let c = self.config();
        let name = format!("synth_{}_{}_seed{}", c.scene, c.trajectory, c.seed);
        let mut rgb = format!("# color images\n# file: '{name}'\n# timestamp filename\n");
        let mut depth = format!("# depth maps\n# file: '{name}'\n# timestamp filename\n");
        let mut assoc = String::new();
        let mut gt = format!(
            "# ground truth trajectory\n# file: '{name}'\n# timestamp tx ty tz qx qy qz qw\n"
        );
        for (i, s) in stamps.iter().enumerate() {
            // Writing to a String cannot fail.
            let _ = writeln!(rgb, "{s} rgb/{s}.png");
            let _ = writeln!(depth, "{s} depth/{s}.png");
            let _ = writeln!(assoc, "{s} rgb/{s}.png {s} depth/{s}.png");
            let p = self.pose(i);
            let (t, q) = (p.translation.vector, p.rotation.coords);
            let _ = writeln!(
                gt,
                "{s} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}",
                t.x, t.y, t.z, q.x, q.y, q.z, q.w
            );
        }
        let cam = c.camera;
        let d = &c.distortion;
        let (lens_comment, mut lens_values) = if d.is_zero() {
            ("Ideal pinhole (no distortion)".to_owned(), String::new())
        } else {
            let name = d.model.name();
            (
                format!("Recorded through a lens, model {name}"),
                format!("model = \"{name}\"\n"),
            )
        };
        if !d.is_zero() {
            for (n, v) in d.model.coefficient_names().iter().zip(d.coefficients()) {
                let _ = writeln!(lens_values, "{n} = {v:?}");
            }
        }
        let mut marker = format!(
            "# Written by `gfsvo synth`: scene {}, trajectory {}, {} frames, seed {}.\n\
             # {lens_comment}; ground truth in groundtruth.txt.\n\
             [camera]\nfx = {:?}\nfy = {:?}\ncx = {:?}\ncy = {:?}\nwidth = {}\nheight = {}\n{lens_values}\n\
             [depth]\nscale = {:?}\nmin_m = 0.1\nmax_m = 10.0\n",
            c.scene,
            c.trajectory,
            c.frames,
            c.seed,
            cam.fx,
            cam.fy,
            cam.cx,
            cam.cy,
            cam.width,
            cam.height,
            DEPTH_SCALE
        );
        // What a user of such a camera writes: intrinsics and depth, and for a time-of-
        // flight camera its kind (the depth noise follows from it).
        if matches!(c.noise.depth_model, DepthModel::TimeOfFlight(_)) {
            marker.push_str("sensor = \"time-of-flight\"\n");
        }
        let imu = self.imu_texts();
        if let Some((_, table)) = &imu {
            marker.push_str(table);
        }
        if let Some((list, _)) = imu {
            let path = dir.join("imu.txt");
            fs::write(&path, list).map_err(io(path))?;
        }
        for (file, text) in [
            ("rgb.txt", rgb),
            ("depth.txt", depth),
            ("associations.txt", assoc),
            ("groundtruth.txt", gt),
            ("synthetic.toml", marker),
        ] {
            let path = dir.join(file);
            fs::write(&path, text).map_err(io(path))?;
        }
        Ok(())
    }
}

/// Depth in metres to 16-bit units of 1/5000 m; 0 (missing) when not representable.
fn depth_units(z: f32) -> u16 {
    let units = (f64::from(z) * DEPTH_SCALE).round();
    if z > 0.0 && units.is_finite() && units <= f64::from(u16::MAX) {
        units as u16
    } else {
        0
    }
}

fn write_png(
    path: &Path,
    bytes: &[u8],
    w: u32,
    h: u32,
    color: ExtendedColorType,
) -> Result<(), SynthError> {
    let file = fs::File::create(path).map_err(io(path))?;
    PngEncoder::new(BufWriter::new(file))
        .write_image(bytes, w, h, color)
        .map_err(|source| SynthError::Encode {
            path: path.to_path_buf(),
            source,
        })
}

/// The folder of the sequence of `config` in the user's cache
/// (`$XDG_CACHE_HOME/gfsvo/` or `~/.cache/gfsvo/`, e.g.
/// `synth_room_slow_300_seed1_r1`), rendering it first if absent. Rendering goes to a
/// temporary folder that is renamed into place when complete, so an interrupted run
/// never leaves a half sequence behind. `progress` gets the frames rendered so far.
///
/// # Errors
/// [`SynthError::NoCacheDir`] when no cache folder is known; the errors of
/// [`SynthSequence::write_tum`] and [`SynthError::Io`] for the rename.
pub fn cached_sequence(
    config: &SynthConfig,
    progress: impl FnMut(usize),
) -> Result<PathBuf, SynthError> {
    let root = cache_root().ok_or(SynthError::NoCacheDir)?.join("gfsvo");
    let dir = root.join(cache_name(config));
    if dir.join("associations.txt").is_file() {
        return Ok(dir);
    }
    fs::create_dir_all(&root).map_err(io(&root))?;
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let tmp = root.join(format!(
        ".{}.tmp-{}-{nanos}",
        cache_name(config),
        std::process::id()
    ));
    let result = SynthSequence::new(config.clone()).write_tum(&tmp, progress);
    if let Err(e) = result {
        let _ = fs::remove_dir_all(&tmp);
        return Err(e);
    }
    match fs::rename(&tmp, &dir) {
        Ok(()) => Ok(dir),
        // Another process finished the same sequence first: keep theirs.
        Err(_) if dir.join("associations.txt").is_file() => {
            let _ = fs::remove_dir_all(&tmp);
            Ok(dir)
        }
        Err(source) => {
            let _ = fs::remove_dir_all(&tmp);
            Err(SynthError::Io { path: dir, source })
        }
    }
}

/// `synth_<scene>_<traj>_<frames>_seed<seed>[_<hash>]_r<revision>`: the hash of the
/// remaining settings appears only when they differ from the defaults.
fn cache_name(config: &SynthConfig) -> String {
    let base = SynthConfig {
        scene: config.scene,
        trajectory: config.trajectory,
        frames: config.frames,
        seed: config.seed,
        ..SynthConfig::default()
    };
    let extra = if *config == base {
        String::new()
    } else {
        // FNV-1a of the config's debug text: stable across runs of the same build.
        let hash = format!("{config:?}")
            .bytes()
            .fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
                (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
            });
        format!("_{hash:016x}")
    };
    format!(
        "synth_{}_{}_{}_seed{}{extra}_r{RENDER_REVISION}",
        config.scene, config.trajectory, config.frames, config.seed
    )
}

fn cache_root() -> Option<PathBuf> {
    let from_env = |name: &str| {
        std::env::var_os(name)
            .map(PathBuf::from)
            .filter(|p| p.is_absolute())
    };
    from_env("XDG_CACHE_HOME").or_else(|| from_env("HOME").map(|home| home.join(".cache")))
}
