//! The payload of a map file: the map laid out by hand, so that the hundreds of
//! megabytes of keypoints, descriptors and observations go to and from the file as
//! fixed-size little-endian records, without a serde call per number. The small,
//! irregular parts (counters, retired keyframes, Manhattan axes, each keyframe's pose
//! and planes) are bincode blobs.
//!
//! ```text
//! head       blob     counters, retired keyframes, world Manhattan axes
//! keyframes  u64 n, then per keyframe in id order:
//!   head     blob     id, pose, loop correction, frame id, stamp, axes, planes
//!   counts   u32 x 2  keypoints, lines
//!   keypoints         u v f32, level u8, angle response depth f32   (21 bytes each)
//!   descriptors       256 bits                                       (32 bytes each)
//!   lines             start end f32 x 4, mean gradient f32           (20 bytes each)
//!   descriptors       256 bits                                       (32 bytes each)
//!   lines 3D          start end f32 x 6, valid u32                   (28 bytes each)
//! points     u64 n, then per point in id order: id u64, position normal f64 x 6,
//!            max min distance f64 x 2, descriptor, first keyframe u64, visible found
//!            u32 x 2, observations u32 n, then n x (keyframe u32, keypoint u32)
//! lines      u64 n, per line: id, start end measured x 2 f64 x 12, measured depths
//!            f64 x 2, descriptor, axis u8 (255: none), first keyframe, visible, found,
//!            observations
//! planes     u64 n, per plane: id, normal f64 x 3, offset f64, first keyframe,
//!            visible, found, observations
//! blob       u32 length, then that many bytes of bincode
//! ```
//!
//! An observation names its keyframe by its place in the file's keyframe list; the
//! keyframes' landmark slots are not stored but linked from the observations on
//! reading, which refuses an observation of a keyframe or feature that does not exist
//! or of a feature another landmark already holds.

use super::{MapFileProblem, codec};
use crate::frontend::features::{Descriptor, FrameFeatures};
use crate::map::manhattan::WorldManhattan;
use crate::map::{
    IdMap, KeyFrame, Landmark, Map, MapCounters, MapLine, MapParts, MapPlane, MapPoint,
    RetiredKeyFrame,
};
use gfs_core::ids::{FrameId, KeyFrameId};
use gfs_core::le_bytes::LeReader;
use gfs_core::stamp::Stamp;
use gfs_lines::{DetectedLine, Line3, Segment};
use gfs_planes::{ManhattanAxes, Plane};
use gfs_points::KeyPoint;
use nalgebra::{Isometry3, Point3};
use serde::{Deserialize, Serialize};
use std::io::Write;

const KEYPOINT_BYTES: usize = 21;
const DESCRIPTOR_BYTES: usize = 32;
const LINE_BYTES: usize = 20;
const LINE3_BYTES: usize = 28;
const OBSERVATION_BYTES: usize = 8;
/// A point's record before its observations.
const POINT_BYTES: usize = 8 + 8 * 8 + DESCRIPTOR_BYTES + 8 + 4 + 4 + 4;
/// A line's record before its observations.
const LINE_RECORD_BYTES: usize = 8 + 14 * 8 + DESCRIPTOR_BYTES + 1 + 8 + 4 + 4 + 4;
/// A plane's record before its observations.
const PLANE_BYTES: usize = 8 + 4 * 8 + 8 + 4 + 4 + 4;
/// Marks a line without a Manhattan axis.
const NO_AXIS: u8 = u8::MAX;

/// What the payload holds besides keyframes and landmarks.
#[derive(Serialize, Deserialize)]
struct Head<R> {
    counters: MapCounters,
    retired: Vec<(KeyFrameId, R)>,
    manhattan: WorldManhattan,
}

/// A keyframe's small parts.
#[derive(Serialize, Deserialize)]
struct KeyFrameHead<P> {
    id: KeyFrameId,
    camera_from_world: Isometry3<f64>,
    loop_correction: Isometry3<f64>,
    frame: FrameId,
    timestamp: Stamp,
    manhattan: Option<ManhattanAxes>,
    planes: P,
}

/// Writes the payload of `map` and `manhattan` to `out`.
pub(super) fn write_payload(
    out: &mut impl Write,
    map: &Map,
    manhattan: &WorldManhattan,
) -> Result<(), MapFileProblem> {
    let mut buf = Vec::with_capacity(1 << 20);
    let head = Head {
        counters: map.counters(),
        retired: map.sorted_retired(),
        manhattan: manhattan.clone(),
    };
    put_blob(&mut buf, &head)?;
    let keyframes = map.sorted_keyframes();
    let ordinal: IdMap<KeyFrameId, u32> = keyframes
        .iter()
        .enumerate()
        .map(|(i, k)| (k.id, i as u32))
        .collect();
    put_u64(&mut buf, keyframes.len() as u64);
    for kf in keyframes {
        put_keyframe(&mut buf, kf)?;
        out.write_all(&buf)?;
        buf.clear();
    }
    let points = map.sorted_points();
    put_u64(&mut buf, points.len() as u64);
    for (id, p) in points {
        put_u64(&mut buf, id.0);
        put_f64s(&mut buf, p.position.iter().chain(p.normal.iter()));
        put_f64s(&mut buf, &[p.max_distance, p.min_distance]);
        put_descriptor(&mut buf, &p.descriptor);
        put_bookkeeping(&mut buf, p, [p.visible, p.found], &ordinal, "point")?;
        flush_full(out, &mut buf)?;
    }
    let lines = map.sorted_lines();
    put_u64(&mut buf, lines.len() as u64);
    for (id, l) in lines {
        put_u64(&mut buf, id.0);
        let ends = [l.start, l.end, l.measured[0], l.measured[1]];
        put_f64s(&mut buf, ends.iter().flat_map(|p| p.iter()));
        put_f64s(&mut buf, &l.measured_depth);
        put_descriptor(&mut buf, &l.descriptor);
        buf.push(l.axis.unwrap_or(NO_AXIS));
        put_bookkeeping(&mut buf, l, [l.visible, l.found], &ordinal, "line")?;
        flush_full(out, &mut buf)?;
    }
    let planes = map.sorted_planes();
    put_u64(&mut buf, planes.len() as u64);
    for (id, p) in planes {
        put_u64(&mut buf, id.0);
        put_f64s(&mut buf, p.normal.iter().chain([&p.offset]));
        put_bookkeeping(&mut buf, p, [p.visible, p.found], &ordinal, "plane")?;
    }
    out.write_all(&buf)?;
    Ok(())
}

/// Hands `buf` on once it holds a megabyte.
fn flush_full(out: &mut impl Write, buf: &mut Vec<u8>) -> Result<(), MapFileProblem> {
    if buf.len() >= 1 << 20 {
        out.write_all(buf)?;
        buf.clear();
    }
    Ok(())
}

fn put_u32(buf: &mut Vec<u8>, v: u32) {
    buf.extend_from_slice(&v.to_le_bytes());
}

fn put_u64(buf: &mut Vec<u8>, v: u64) {
    buf.extend_from_slice(&v.to_le_bytes());
}

fn put_f32s(buf: &mut Vec<u8>, values: &[f32]) {
    for v in values {
        buf.extend_from_slice(&v.to_le_bytes());
    }
}

fn put_f64s<'a>(buf: &mut Vec<u8>, values: impl IntoIterator<Item = &'a f64>) {
    for v in values {
        buf.extend_from_slice(&v.to_le_bytes());
    }
}

fn put_descriptor(buf: &mut Vec<u8>, d: &Descriptor) {
    for word in d {
        buf.extend_from_slice(&word.to_le_bytes());
    }
}

/// A bincode blob: its length, then its bytes.
fn put_blob(buf: &mut Vec<u8>, value: &impl Serialize) -> Result<(), MapFileProblem> {
    let bytes = bincode::serde::encode_to_vec(value, codec())?;
    let len = u32::try_from(bytes.len())
        .map_err(|_| MapFileProblem::Invalid(format!("a part of {} bytes", bytes.len())))?;
    put_u32(buf, len);
    buf.extend_from_slice(&bytes);
    Ok(())
}

fn put_keyframe(buf: &mut Vec<u8>, kf: &KeyFrame) -> Result<(), MapFileProblem> {
    let f = &kf.features;
    let head = KeyFrameHead {
        id: kf.id,
        camera_from_world: kf.camera_from_world,
        loop_correction: kf.loop_correction,
        frame: f.id,
        timestamp: f.timestamp,
        manhattan: f.manhattan,
        planes: &f.planes,
    };
    put_blob(buf, &head)?;
    put_u32(buf, f.keypoints.len() as u32);
    put_u32(buf, f.lines.len() as u32);
    buf.reserve(
        f.keypoints.len() * (KEYPOINT_BYTES + DESCRIPTOR_BYTES)
            + f.lines.len() * (LINE_BYTES + DESCRIPTOR_BYTES + LINE3_BYTES),
    );
    for k in &f.keypoints {
        put_f32s(buf, &[k.u, k.v]);
        // Levels are below the pyramid's, which counts them in a u8.
        buf.push(u8::try_from(k.level).unwrap_or(u8::MAX));
        put_f32s(buf, &[k.angle, k.response, k.depth]);
    }
    for d in &f.point_descriptors {
        put_descriptor(buf, d);
    }
    for l in &f.lines {
        let s = &l.segment;
        put_f32s(
            buf,
            &[s.start[0], s.start[1], s.end[0], s.end[1], l.mean_gradient],
        );
    }
    for d in &f.line_descriptors {
        put_descriptor(buf, d);
    }
    for l in &f.lines3d {
        put_f32s(buf, &l.start);
        put_f32s(buf, &l.end);
        put_u32(buf, l.valid);
    }
    Ok(())
}

/// A landmark's first keyframe, sighting counts `[visible, found]` and observations
/// (keyframes by their place in the file).
fn put_bookkeeping<L: Landmark>(
    buf: &mut Vec<u8>,
    landmark: &L,
    sightings: [u32; 2],
    ordinal: &IdMap<KeyFrameId, u32>,
    kind: &str,
) -> Result<(), MapFileProblem> {
    put_u64(buf, landmark.first_kf().0);
    put_u32(buf, sightings[0]);
    put_u32(buf, sightings[1]);
    let observations = landmark.observations();
    put_u32(buf, observations.len() as u32);
    for (kf, index) in observations {
        let Some(at) = ordinal.get(kf) else {
            return Err(MapFileProblem::Invalid(format!(
                "a map {kind} is observed by keyframe {}, which is not in the map",
                kf.0
            )));
        };
        put_u32(buf, *at);
        put_u32(buf, *index);
    }
    Ok(())
}

/// Reads the payload through, in order; every length is checked before it is used.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    /// The next `len` bytes, which hold `what`.
    fn take(&mut self, len: usize, what: &dyn Fn() -> String) -> Result<&'a [u8], MapFileProblem> {
        let end = self.at.checked_add(len).filter(|e| *e <= self.bytes.len());
        let Some(end) = end else {
            return Err(MapFileProblem::Invalid(format!(
                "the payload ends inside {}",
                what()
            )));
        };
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    /// The next `n` records of `size` bytes each, which hold `what`.
    fn records(
        &mut self,
        n: u64,
        size: usize,
        what: &dyn Fn() -> String,
    ) -> Result<std::slice::ChunksExact<'a, u8>, MapFileProblem> {
        let len = usize::try_from(n)
            .ok()
            .and_then(|n| n.checked_mul(size))
            .unwrap_or(usize::MAX);
        Ok(self.take(len, what)?.chunks_exact(size))
    }

    fn u32(&mut self, what: &dyn Fn() -> String) -> Result<u32, MapFileProblem> {
        Ok(LeReader::new(self.take(4, what)?, 0).u32())
    }

    fn u64(&mut self, what: &dyn Fn() -> String) -> Result<u64, MapFileProblem> {
        Ok(LeReader::new(self.take(8, what)?, 0).u64())
    }

    fn blob<T: serde::de::DeserializeOwned>(
        &mut self,
        what: &dyn Fn() -> String,
    ) -> Result<T, MapFileProblem> {
        let len = self.u32(what)? as usize;
        let bytes = self.take(len, what)?;
        let (value, used) = bincode::serde::decode_from_slice(bytes, codec())?;
        if used != len {
            return Err(MapFileProblem::Invalid(format!(
                "{} ends after {used} of its {len} bytes",
                what()
            )));
        }
        Ok(value)
    }
}

fn f32_at(r: &mut LeReader) -> f32 {
    f32::from_le_bytes(r.take())
}

fn descriptor_at(r: &mut LeReader) -> Descriptor {
    [(); 4].map(|()| r.u64())
}

fn point3_at(r: &mut LeReader) -> Point3<f64> {
    Point3::new(r.f64(), r.f64(), r.f64())
}

/// The map and Manhattan axes of a whole payload.
pub(super) fn read_payload(bytes: &[u8]) -> Result<(Map, WorldManhattan), MapFileProblem> {
    let mut cursor = Cursor { bytes, at: 0 };
    let head: Head<RetiredKeyFrame> = cursor.blob(&|| "the map's counters".to_owned())?;
    let n = cursor.u64(&|| "the keyframe count".to_owned())?;
    // Each keyframe takes at least its blob's length and its counts.
    let n = usize::try_from(n).unwrap_or(usize::MAX);
    if n > bytes.len() / 12 {
        return Err(MapFileProblem::Invalid(format!(
            "{n} keyframes announced in {} bytes",
            bytes.len()
        )));
    }
    let mut keyframes = Vec::with_capacity(n);
    for i in 0..n {
        keyframes.push(read_keyframe(&mut cursor, i)?);
    }
    let points = read_landmarks(&mut cursor, &mut keyframes, "point", POINT_BYTES, |r| {
        let position = point3_at(r);
        let normal = point3_at(r).coords;
        let (max_distance, min_distance) = (r.f64(), r.f64());
        let descriptor = descriptor_at(r);
        MapPoint {
            position,
            descriptor,
            observations: Vec::new(),
            normal,
            max_distance,
            min_distance,
            first_kf: KeyFrameId(0),
            visible: 0,
            found: 0,
        }
    })?;
    let lines = read_landmarks(
        &mut cursor,
        &mut keyframes,
        "line",
        LINE_RECORD_BYTES,
        |r| {
            let [start, end, m0, m1] = [(); 4].map(|()| point3_at(r));
            let measured_depth = [r.f64(), r.f64()];
            let descriptor = descriptor_at(r);
            let axis = r.take::<1>()[0];
            MapLine {
                start,
                end,
                measured: [m0, m1],
                measured_depth,
                descriptor,
                observations: Vec::new(),
                axis: (axis != NO_AXIS).then_some(axis),
                first_kf: KeyFrameId(0),
                visible: 0,
                found: 0,
            }
        },
    )?;
    let planes = read_landmarks(&mut cursor, &mut keyframes, "plane", PLANE_BYTES, |r| {
        MapPlane {
            normal: point3_at(r).coords,
            offset: r.f64(),
            observations: Vec::new(),
            first_kf: KeyFrameId(0),
            visible: 0,
            found: 0,
        }
    })?;
    if cursor.at != bytes.len() {
        return Err(MapFileProblem::Invalid(format!(
            "the map ends after {} of the payload's {} bytes",
            cursor.at,
            bytes.len()
        )));
    }
    let map = Map::from_parts(MapParts {
        counters: head.counters,
        keyframes,
        points,
        lines,
        planes,
        retired: head.retired,
    });
    Ok((map, head.manhattan))
}

fn read_keyframe(cursor: &mut Cursor, i: usize) -> Result<KeyFrame, MapFileProblem> {
    let what = |part: &str| format!("keyframe {i} of the file's {part}");
    let head: KeyFrameHead<Vec<Plane>> = cursor.blob(&|| what("head"))?;
    let keypoints = u64::from(cursor.u32(&|| what("keypoint count"))?);
    let lines = u64::from(cursor.u32(&|| what("line count"))?);
    let keypoints: Vec<KeyPoint> = cursor
        .records(keypoints, KEYPOINT_BYTES, &|| what("keypoints"))?
        .map(|c| {
            let mut r = LeReader::new(c, 0);
            let (u, v) = (f32_at(&mut r), f32_at(&mut r));
            let level = u32::from(r.take::<1>()[0]);
            KeyPoint {
                u,
                v,
                level,
                angle: f32_at(&mut r),
                response: f32_at(&mut r),
                depth: f32_at(&mut r),
            }
        })
        .collect();
    let n = keypoints.len() as u64;
    let point_descriptors = read_descriptors(cursor, n, &|| what("keypoint descriptors"))?;
    let detected: Vec<DetectedLine> = cursor
        .records(lines, LINE_BYTES, &|| what("lines"))?
        .map(|c| {
            let mut r = LeReader::new(c, 0);
            let [u0, v0, u1, v1, mean_gradient] = [(); 5].map(|()| f32_at(&mut r));
            DetectedLine {
                segment: Segment::new(u0, v0, u1, v1),
                mean_gradient,
            }
        })
        .collect();
    let line_descriptors = read_descriptors(cursor, lines, &|| what("line descriptors"))?;
    let lines3d: Vec<Line3> = cursor
        .records(lines, LINE3_BYTES, &|| what("3D lines"))?
        .map(|c| {
            let mut r = LeReader::new(c, 0);
            Line3 {
                start: [(); 3].map(|()| f32_at(&mut r)),
                end: [(); 3].map(|()| f32_at(&mut r)),
                valid: r.u32(),
            }
        })
        .collect();
    let features = FrameFeatures {
        id: head.frame,
        timestamp: head.timestamp,
        keypoints,
        point_descriptors,
        lines: detected,
        line_descriptors,
        lines3d,
        manhattan: head.manhattan,
        planes: head.planes,
        depth: Default::default(),
    };
    Ok(KeyFrame {
        id: head.id,
        camera_from_world: head.camera_from_world,
        point_ids: vec![None; features.keypoints.len()],
        line_ids: vec![None; features.lines.len()],
        plane_ids: vec![None; features.planes.len()],
        features,
        loop_correction: head.loop_correction,
    })
}

fn read_descriptors(
    cursor: &mut Cursor,
    n: u64,
    what: &dyn Fn() -> String,
) -> Result<Vec<Descriptor>, MapFileProblem> {
    Ok(cursor
        .records(n, DESCRIPTOR_BYTES, what)?
        .map(|c| descriptor_at(&mut LeReader::new(c, 0)))
        .collect())
}

/// The landmarks of kind `L` (records of `size` bytes before their bookkeeping, read
/// by `record`), each linked into the slots of the keyframes that observe it.
fn read_landmarks<L: Landmark>(
    cursor: &mut Cursor,
    keyframes: &mut [KeyFrame],
    kind: &str,
    size: usize,
    record: impl Fn(&mut LeReader) -> L,
) -> Result<Vec<(L::Id, L)>, MapFileProblem> {
    let n = cursor.u64(&|| format!("the map {kind} count"))?;
    let n = usize::try_from(n).unwrap_or(usize::MAX);
    if n > cursor.bytes.len() / size {
        return Err(MapFileProblem::Invalid(format!(
            "{n} map {kind}s announced in {} bytes",
            cursor.bytes.len()
        )));
    }
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let what = || format!("map {kind} {i} of the file");
        let fixed = cursor.take(size, &what)?;
        let mut r = LeReader::new(fixed, 0);
        let id = L::id(r.u64());
        let mut landmark = record(&mut r);
        let (first_kf, visible, found) = (KeyFrameId(r.u64()), r.u32(), r.u32());
        let count = u64::from(r.u32());
        landmark.set_first_kf(first_kf);
        let (v, f) = landmark.sightings_mut();
        (*v, *f) = (visible, found);
        let observations = cursor.records(count, OBSERVATION_BYTES, &what)?;
        let list = landmark.observations_mut();
        list.reserve_exact(observations.len());
        for c in observations {
            let mut r = LeReader::new(c, 0);
            let (at, index) = (r.u32() as usize, r.u32());
            let keyframe = keyframes.get_mut(at);
            let kf = keyframe.as_ref().map(|k| k.id);
            let slot = keyframe.and_then(|k| L::slots_mut(k).get_mut(index as usize));
            match (slot, kf) {
                (Some(slot @ None), Some(kf)) => {
                    *slot = Some(id);
                    list.push((kf, index));
                }
                _ => {
                    return Err(MapFileProblem::Invalid(format!(
                        "map {kind} {id:?} observed by feature {index} of the file's \
                         keyframe {at}, which does not exist or is observed twice"
                    )));
                }
            }
        }
        out.push((id, landmark));
    }
    Ok(out)
}
