//! The consistency of a map that came from outside the process (a map file): every
//! link goes both ways, every id is below its counter, every number is finite, so
//! that the map's methods, which index by these links, never panic on it.

use super::{KeyFrame, Landmark, Map, Store};
use gfs_core::ids::KeyFrameId;
use nalgebra::Isometry3;

fn finite_pose(pose: &Isometry3<f64>) -> bool {
    let q = pose.rotation.coords;
    pose.translation.vector.iter().all(|v| v.is_finite())
        && q.iter().all(|v| v.is_finite())
        && (q.norm() - 1.0).abs() < 1e-6
}

impl Map {
    /// Checks the invariant of [`Map`] (keyframe slot `i` holds landmark `l` exactly
    /// when `l`'s observations hold `(k, i)`, no landmark without observations), the
    /// id counters, the features of each keyframe (their keypoints from a pyramid of
    /// `levels` levels), finite poses with unit rotations, and finite landmarks.
    ///
    /// # Errors
    /// What is wrong first, naming the keyframe or landmark.
    pub fn validate(&self, levels: u8) -> Result<(), String> {
        for (id, kf) in &self.keyframes {
            self.validate_keyframe(*id, kf, levels)?;
        }
        self.validate_links::<super::MapPoint>("point")?;
        self.validate_links::<super::MapLine>("line")?;
        self.validate_links::<super::MapPlane>("plane")?;
        for (id, p) in &self.points.items {
            let numbers = p.position.iter().chain(p.normal.iter());
            if !numbers
                .chain([&p.max_distance, &p.min_distance])
                .all(|v| v.is_finite())
            {
                return Err(format!("map point {id:?} has a non-finite number"));
            }
        }
        for (id, l) in &self.lines.items {
            let ends = [l.start, l.end, l.measured[0], l.measured[1]];
            let finite = ends.iter().all(|p| p.iter().all(|v| v.is_finite()))
                && l.measured_depth.iter().all(|v| v.is_finite());
            if !finite || l.axis.is_some_and(|a| a > 2) {
                return Err(format!(
                    "map line {id:?} has a non-finite end or an axis beyond 2"
                ));
            }
        }
        for (id, p) in &self.planes.items {
            if !(p.offset.is_finite() && (p.normal.norm() - 1.0).abs() < 1e-6) {
                return Err(format!(
                    "map plane {id:?} has no unit normal or a non-finite offset"
                ));
            }
        }
        for (id, r) in &self.retired {
            let known = |k: KeyFrameId| k.0 < self.next_keyframe;
            if !known(*id) || r.parent.is_some_and(|p| !known(p)) {
                return Err(format!(
                    "retired keyframe {id:?} or its parent is beyond the keyframe counter"
                ));
            }
            if !(finite_pose(&r.correction) && finite_pose(&r.parent_correction)) {
                return Err(format!(
                    "retired keyframe {id:?} has a non-finite correction"
                ));
            }
        }
        Ok(())
    }

    fn validate_keyframe(&self, id: KeyFrameId, kf: &KeyFrame, levels: u8) -> Result<(), String> {
        let fail = |what: String| Err(format!("keyframe {}: {what}", id.0));
        if kf.id != id || id.0 >= self.next_keyframe {
            return fail(format!(
                "stored as {:?}, keyframe counter at {}",
                kf.id, self.next_keyframe
            ));
        }
        if !finite_pose(&kf.camera_from_world) || !finite_pose(&kf.loop_correction) {
            return fail("pose or loop correction not finite or not a rotation".to_owned());
        }
        kf.features.check().or_else(|e| fail(e.what))?;
        if let Some(k) = kf
            .features
            .keypoints
            .iter()
            .find(|k| k.level >= u32::from(levels))
        {
            return fail(format!(
                "keypoint at level {} of a {levels}-level pyramid",
                k.level
            ));
        }
        if !kf.features.depth.is_empty() {
            return fail("holds a depth grid (the map's keyframes hold none)".to_owned());
        }
        let f = &kf.features;
        let counts = [
            ("point_ids", kf.point_ids.len(), f.keypoints.len()),
            ("line_ids", kf.line_ids.len(), f.lines.len()),
            ("plane_ids", kf.plane_ids.len(), f.planes.len()),
        ];
        for (what, got, want) in counts {
            if got != want {
                return fail(format!("{what} has {got} entries, expected {want}"));
            }
        }
        Ok(())
    }

    /// Both directions of the links of landmark kind `L`, in time linear in the links:
    /// every observation's slot links back, no landmark lists an observation twice, and
    /// as many slots are linked as observations are listed (so every linked slot is
    /// one of them).
    fn validate_links<L: Landmark>(&self, kind: &str) -> Result<(), String> {
        let store: &Store<L> = L::store(self);
        let mut observations = 0;
        let mut sorted = Vec::new();
        for (id, landmark) in &store.items {
            // Typed ids order as their counters.
            if *id >= L::id(store.next) {
                return Err(format!(
                    "map {kind} {id:?} is beyond the counter {}",
                    store.next
                ));
            }
            if landmark.observations().is_empty() {
                return Err(format!("map {kind} {id:?} has no observation"));
            }
            for &(kf, index) in landmark.observations() {
                let slot = self
                    .keyframes
                    .get(&kf)
                    .and_then(|k| L::slots(k).get(index as usize));
                if slot != Some(&Some(*id)) {
                    return Err(format!(
                        "map {kind} {id:?} observed by feature {index} of keyframe {}, \
                         which does not link it back",
                        kf.0
                    ));
                }
            }
            sorted.clear();
            sorted.extend_from_slice(landmark.observations());
            sorted.sort_unstable();
            if sorted.windows(2).any(|w| w[0] == w[1]) {
                return Err(format!("map {kind} {id:?} lists an observation twice"));
            }
            observations += sorted.len();
        }
        let linked: usize = self
            .keyframes
            .values()
            .map(|k| L::slots(k).iter().flatten().count())
            .sum();
        if observations != linked {
            return Err(format!(
                "map {kind}s list {observations} observations, keyframes link {linked}"
            ));
        }
        Ok(())
    }
}
