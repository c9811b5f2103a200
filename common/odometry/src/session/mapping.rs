//! The mapping half of the odometry (the `mapper` service): owns the global map, turns
//! keyframe requests into keyframes with local mapping, finds the frames of
//! relocalisation requests in the whole map, and answers each request with the
//! tracker's neighbourhood of it; the whole map is its checkpoint.

use super::messages::{
    KeyFrameRequest, MapUpdate, MapUpdateRef, RelocalisationRequest, Relocalised,
};
use crate::config::OdometryConfig;
use crate::loop_closing::{LoopCloser, LoopClosure, LoopCorrection, apply_correction};
use crate::map::manhattan::WorldManhattan;
use crate::map::{Map, NeighbourhoodBounds};
use crate::map_file::SavedMap;
use crate::mapping::mapper::Mapper;
use crate::tracking::matching::ScalePyramid;
use crate::tracking::relocalisation::against_map::MapRelocaliser;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::KeyFrameId;
use nalgebra::Isometry3;

/// Owns the map and runs local mapping on keyframe requests.
pub struct MappingSession {
    mapper: Mapper,
    /// `None` with loop closing off, or when a loop stage detects the loops and sends
    /// its corrections ([`Self::apply`]).
    loops: Option<LoopCloser>,
    closures: Vec<LoopClosure>,
    /// Every keyframe of the map as a bag of words, for lost frames, in every mode.
    relocaliser: MapRelocaliser,
    map: Map,
    manhattan: WorldManhattan,
    last_applied: u64,
    last_keyframe: Option<KeyFrameId>,
    /// The answer of the last request applied when it was a relocalisation that found
    /// its frame (sent again with the map to a request sent again).
    relocalised: Option<Relocalised>,
    /// The keyframe the tracker's map is centred on: the last one made, or the one the
    /// last lost frame was found against.
    centre: Option<KeyFrameId>,
    neighbourhood: NeighbourhoodBounds,
    /// Localisation on a loaded map: no keyframe is added, no landmark changed; a
    /// keyframe request only moves the tracker's neighbourhood to its reference.
    fixed: bool,
    /// Keyframes made since this mapping half started.
    keyframes_added: usize,
    /// Lost frames found in the whole map since this mapping half started.
    relocalisations: usize,
}

impl MappingSession {
    /// A mapping half for an undistorted `camera` whose ORB pyramid has `levels` levels
    /// `scale_factor` apart.
    pub fn new(
        config: &OdometryConfig,
        camera: PinholeCamera,
        scale_factor: f64,
        levels: u8,
    ) -> Self {
        let scale = ScalePyramid::new(scale_factor, levels);
        let detects = config.loop_closing.enabled;
        Self {
            mapper: Mapper::new(config, camera, scale),
            loops: detects.then(|| LoopCloser::new(config, camera, scale)),
            closures: Vec::new(),
            relocaliser: MapRelocaliser::new(config, camera, scale),
            manhattan: WorldManhattan::new(config.tracking.use_manhattan),
            map: Map::default(),
            last_applied: 0,
            last_keyframe: None,
            relocalised: None,
            centre: None,
            neighbourhood: NeighbourhoodBounds::of(config),
            fixed: false,
            keyframes_added: 0,
            relocalisations: 0,
        }
    }

    /// A mapping half whose loops a loop stage detects: its keyframes are not searched
    /// here (no vocabulary loaded), the stage's corrections come through [`Self::apply`].
    pub fn with_loop_stage(
        config: &OdometryConfig,
        camera: PinholeCamera,
        scale_factor: f64,
        levels: u8,
    ) -> Self {
        let mut config = config.clone();
        config.loop_closing.enabled = false;
        Self::new(&config, camera, scale_factor, levels)
    }

    /// The global map.
    pub fn map(&self) -> &Map {
        &self.map
    }

    /// The loops closed so far (since this mapping half started).
    pub fn closures(&self) -> &[LoopClosure] {
        &self.closures
    }

    /// The world Manhattan axes of the map.
    pub fn manhattan(&self) -> &WorldManhattan {
        &self.manhattan
    }

    /// Keyframes made since this mapping half started.
    pub fn keyframes_added(&self) -> usize {
        self.keyframes_added
    }

    /// Lost frames found in the whole map since this mapping half started.
    pub fn relocalisations(&self) -> usize {
        self.relocalisations
    }

    /// Takes over a map saved by an earlier run, before the first request; with
    /// `fixed` (localisation) it is never changed. Its keyframes' bags of words are
    /// computed for the relocaliser now, and for the loop closer at its first search.
    pub fn start_from(&mut self, saved: SavedMap, fixed: bool) {
        self.map = saved.map;
        self.map.canonicalise();
        self.manhattan = saved.manhattan;
        self.fixed = fixed;
        self.relocaliser.sync(&self.map);
    }

    /// Holds the map fixed from now on, as [`Self::start_from`] with `fixed` does (a
    /// localising mapping half resumed from its checkpoint).
    pub fn hold_fixed(&mut self) {
        self.fixed = true;
    }

    /// The keyframe of the map nearest to `world_from_camera`
    /// ([`Map::nearest_keyframe`] within the tracker's view bounds).
    pub fn nearest_keyframe(&self, world_from_camera: &Isometry3<f64>) -> Option<KeyFrameId> {
        self.map
            .nearest_keyframe(world_from_camera, &self.neighbourhood)
    }

    /// The number of the last request applied (0 before the first).
    pub fn last_applied(&self) -> u64 {
        self.last_applied
    }

    /// Makes the request's frame a keyframe and runs local mapping, unless a request
    /// with this number was applied already (a request sent again after a restart).
    /// Returns the tracker's map to send back ([`Self::update`]).
    pub fn insert(&mut self, request: KeyFrameRequest) -> MapUpdate {
        self.insert_until(request, &|| false)
    }

    /// [`Self::insert`] with a local BA that stops early once `stop` answers true: the
    /// realtime mapper stage yields to the next keyframe request or to its time budget.
    /// Lockstep and inline runs never stop early, so that they stay reproducible.
    pub fn insert_until(
        &mut self,
        mut request: KeyFrameRequest,
        stop: &dyn Fn() -> bool,
    ) -> MapUpdate {
        if self.fixed {
            return self.recentre(&request);
        }
        if request.seq > self.last_applied {
            if request.reset {
                self.map.clear_keyframes();
            }
            request.sightings.add_to(&mut self.map);
            if let Some(new_from_old) = self.correction_since(&request) {
                let world_from_camera = new_from_old * request.frame.camera_from_world.inverse();
                request.frame.camera_from_world = world_from_camera.inverse();
            }
            self.manhattan = request.manhattan;
            let kf = self.mapper.add_keyframe_until(
                &mut self.map,
                &request.frame,
                &mut self.manhattan,
                stop,
            );
            // A canonical layout, as a mapper restarted from this map will have: local
            // mapping then goes on the same whether or not the mapper was restarted, and
            // the search for loops sees the map a loop stage decodes.
            self.map.canonicalise();
            if let Some(correction) = self
                .loops
                .as_mut()
                .and_then(|loops| loops.after_keyframe(&self.map, kf))
            {
                self.apply(&correction);
            }
            self.relocaliser.sync(&self.map);
            self.keyframes_added += 1;
            self.last_applied = request.seq;
            self.last_keyframe = Some(kf);
            self.centre = Some(kf);
            self.relocalised = None;
        }
        self.update()
    }

    /// A fixed map's answer to a keyframe request: the neighbourhood of the frame's
    /// reference keyframe, which the answer names as its keyframe (the tracker refers
    /// to it and centres on it). Nothing else changes.
    fn recentre(&mut self, request: &KeyFrameRequest) -> MapUpdate {
        if request.seq > self.last_applied {
            self.last_applied = request.seq;
            let reference = request.tracked_against.map(|a| a.reference);
            if let Some(kf) = reference.filter(|kf| self.map.keyframe(*kf).is_some()) {
                self.centre = Some(kf);
            }
            self.last_keyframe = self.centre;
            self.relocalised = None;
        }
        self.update()
    }

    /// Looks for the request's lost frame in the whole map (bag-of-words candidates
    /// among every keyframe, verified geometrically), unless a request with this number
    /// was applied already. The map is not changed. Returns the map to send back, with
    /// the frame's pose when it was found ([`MapUpdate::relocalised`]).
    pub fn relocalise(&mut self, request: &RelocalisationRequest) -> MapUpdate {
        if request.seq > self.last_applied {
            let features = &request.features;
            let found = self
                .relocaliser
                .relocalise(&self.map, features, features.id.0);
            tracing::info!(
                frame = %features.id,
                keyframe = ?found.as_ref().map(|f| f.keyframe),
                inliers = found.as_ref().map_or(0, |f| f.inliers),
                "relocalisation against the whole map"
            );
            self.relocalised = found.map(|f| Relocalised {
                frame: features.id,
                timestamp: features.timestamp,
                keyframe: f.keyframe,
                camera_from_world: f.camera_from_world,
                point_ids: f.point_ids,
                inliers: f.inliers,
            });
            self.last_applied = request.seq;
            self.last_keyframe = None;
            if let Some(found) = &self.relocalised {
                self.centre = Some(found.keyframe);
                self.relocalisations += 1;
            }
        }
        self.update()
    }

    /// The loop corrections applied since the request's frame was tracked (realtime: the
    /// tracker had not seen them yet), as its reference keyframe received them; `None`
    /// when there were none. Without this the frame would go into the corrected map at
    /// its uncorrected pose, and the tracker would take the correction in as no shift.
    fn correction_since(&self, request: &KeyFrameRequest) -> Option<Isometry3<f64>> {
        let against = request.tracked_against.filter(|_| !request.reset)?;
        if against.corrections == self.map.corrections() {
            return None;
        }
        let now = self.map.keyframe_correction(against.reference)?;
        Some(now * against.reference_correction.inverse())
    }

    /// Applies a loop correction (the loop stage's, between keyframes) to the map.
    /// Returns true when it was applied; a stale one is dropped.
    pub fn apply(&mut self, correction: &LoopCorrection) -> bool {
        let applied = self.correct(correction);
        self.map.canonicalise();
        applied
    }

    /// Applies `correction`, then fuses around its current keyframe (its neighbours
    /// now see the old side's landmarks too).
    fn correct(&mut self, correction: &LoopCorrection) -> bool {
        let Some(closure) = apply_correction(&mut self.map, correction) else {
            return false;
        };
        self.mapper.fuse_around(&mut self.map, closure.current);
        self.closures.push(closure);
        true
    }

    /// The tracker's map answering the last request applied: the neighbourhood of the
    /// keyframe it made or the keyframe its lost frame was found against
    /// ([`Self::update_around`]).
    pub fn update(&self) -> MapUpdate {
        match self.centre {
            Some(kf) => self.update_around(kf),
            None => self.checkpoint().to_owned(),
        }
    }

    /// The tracker's map around keyframe `centre`, answering the last request applied:
    /// `centre`, the keyframes sharing its view, those covisible with it and their
    /// neighbours, at most `[mapping] tracker_keyframes`, with their landmarks
    /// ([`Map::neighbourhood_of`]). A `centre` not in the map gives a map without
    /// keyframes.
    pub fn update_around(&self, centre: KeyFrameId) -> MapUpdate {
        let keep = self.map.neighbourhood_of(centre, &self.neighbourhood);
        MapUpdate {
            seq: self.last_applied,
            keyframe: self.last_keyframe.filter(|kf| keep.contains(kf)),
            map: self.map.neighbourhood(&keep),
            manhattan: self.manhattan.clone(),
            recent_points: Vec::new(),
            relocalised: self.relocalised.clone(),
        }
    }

    /// The whole map with what a restarted mapping half needs to go on (its checkpoint;
    /// also what the loop stage searches).
    pub fn checkpoint(&self) -> MapUpdateRef<'_> {
        MapUpdateRef {
            seq: self.last_applied,
            keyframe: self.last_keyframe,
            map: &self.map,
            manhattan: &self.manhattan,
            recent_points: self.mapper.recent_points(),
            relocalised: self.relocalised.as_ref(),
        }
    }

    /// Resumes from [`Self::checkpoint`] as the old mapping half saved it.
    pub fn restore(&mut self, update: MapUpdate) {
        self.last_applied = update.seq;
        self.last_keyframe = update.keyframe;
        self.map = update.map;
        self.map.canonicalise();
        self.manhattan = update.manhattan;
        self.mapper.restore_recent_points(update.recent_points);
        self.centre = update
            .relocalised
            .as_ref()
            .map(|r| r.keyframe)
            .or(update.keyframe);
        self.relocalised = update.relocalised;
        self.relocaliser.sync(&self.map);
    }
}
