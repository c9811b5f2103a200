//! What the map needs of every landmark kind (points, lines, planes), so that
//! linking, unlinking, removal and merging are written once: a landmark lists the
//! keyframe features that observe it, and each keyframe has one slot per feature of
//! that kind pointing back at it.

use super::{IdMap, KeyFrame};
use crate::frontend::features::Descriptor;
use gfs_core::ids::{KeyFrameId, MapLineId, MapPlaneId, MapPointId};
use std::hash::Hash;

/// A kind of landmark stored in the map.
pub trait Landmark {
    /// Its typed id.
    type Id: LandmarkId<Landmark = Self>;
    /// The id of the `n`-th landmark of this kind created.
    fn id(n: u64) -> Self::Id;
    /// Keyframes that observe it, with the feature index in each.
    fn observations(&self) -> &[(KeyFrameId, u32)];
    /// The same, to link and unlink.
    fn observations_mut(&mut self) -> &mut Vec<(KeyFrameId, u32)>;
    /// The keyframe that created it (the one its geometry is anchored to).
    fn first_kf(&self) -> KeyFrameId;
    /// Sets [`Self::first_kf`].
    fn set_first_kf(&mut self, kf: KeyFrameId);
    /// Its sighting counts: frames that predicted it in view, frames that matched it.
    fn sightings_mut(&mut self) -> (&mut u32, &mut u32);
    /// A keyframe's slots of this kind: the landmark each feature observes.
    fn slots(keyframe: &KeyFrame) -> &[Option<Self::Id>];
    /// The same, to link and unlink.
    fn slots_mut(keyframe: &mut KeyFrame) -> &mut [Option<Self::Id>];
    /// This kind's store in the map, and the keyframes (borrowed apart).
    fn store_mut(map: &mut super::Map) -> (&mut IdMap<KeyFrameId, KeyFrame>, &mut Store<Self>)
    where
        Self: Sized;
    /// This kind's store in the map.
    fn store(map: &super::Map) -> &Store<Self>
    where
        Self: Sized;
}

/// A landmark kind matched by binary descriptor (points and lines; planes are matched
/// by geometry).
pub trait Described: Landmark {
    /// Its representative descriptor.
    fn descriptor_mut(&mut self) -> &mut Descriptor;
    /// The descriptor of feature `index` of a keyframe.
    fn feature_descriptor(keyframe: &KeyFrame, index: usize) -> Option<Descriptor>;
}

/// The id of a landmark kind, so that a map method called with an id knows the kind.
pub trait LandmarkId:
    Copy + Eq + Ord + Hash + std::fmt::Debug + serde::Serialize + serde::de::DeserializeOwned + 'static
{
    /// The landmark kind.
    type Landmark: Landmark<Id = Self>;
}

/// Implements [`Landmark`] and [`LandmarkId`] for a landmark struct whose fields
/// `observations`, `first_kf`, `visible` and `found` hold its bookkeeping, whose
/// keyframe slots are `KeyFrame::$slots` and whose store is `Map::$store`.
macro_rules! landmark_kind {
    ($landmark:ident, $id:ident, $slots:ident, $store:ident) => {
        impl LandmarkId for $id {
            type Landmark = super::$landmark;
        }

        impl Landmark for super::$landmark {
            type Id = $id;

            fn id(n: u64) -> $id {
                $id(n)
            }

            fn observations(&self) -> &[(KeyFrameId, u32)] {
                &self.observations
            }

            fn observations_mut(&mut self) -> &mut Vec<(KeyFrameId, u32)> {
                &mut self.observations
            }

            fn first_kf(&self) -> KeyFrameId {
                self.first_kf
            }

            fn set_first_kf(&mut self, kf: KeyFrameId) {
                self.first_kf = kf;
            }

            fn sightings_mut(&mut self) -> (&mut u32, &mut u32) {
                (&mut self.visible, &mut self.found)
            }

            fn slots(keyframe: &KeyFrame) -> &[Option<$id>] {
                &keyframe.$slots
            }

            fn slots_mut(keyframe: &mut KeyFrame) -> &mut [Option<$id>] {
                &mut keyframe.$slots
            }

            fn store_mut(
                map: &mut super::Map,
            ) -> (&mut IdMap<KeyFrameId, KeyFrame>, &mut Store<Self>) {
                (&mut map.keyframes, &mut map.$store)
            }

            fn store(map: &super::Map) -> &Store<Self> {
                &map.$store
            }
        }
    };
}

landmark_kind!(MapPoint, MapPointId, point_ids, points);
landmark_kind!(MapLine, MapLineId, line_ids, lines);
landmark_kind!(MapPlane, MapPlaneId, plane_ids, planes);

/// The landmarks of one kind, keyed by id, and the next id to give.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Store<L: Landmark> {
    pub(super) items: IdMap<L::Id, L>,
    pub(super) next: u64,
}

impl<L: Landmark> Default for Store<L> {
    fn default() -> Self {
        Self {
            items: IdMap::default(),
            next: 0,
        }
    }
}

impl<L: Landmark> Store<L> {
    /// A landmark by id.
    pub fn get(&self, id: L::Id) -> Option<&L> {
        self.items.get(&id)
    }

    /// Number of landmarks.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// True without landmarks.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// All ids (arbitrary order).
    pub fn ids(&self) -> impl Iterator<Item = L::Id> + '_ {
        self.items.keys().copied()
    }
}

/// The descriptor with the least median distance to the others (ORB-SLAM's
/// distinctive descriptor).
pub(super) fn most_central(descriptors: &[Descriptor]) -> Option<Descriptor> {
    let n = descriptors.len();
    if n <= 2 {
        return descriptors.first().copied();
    }
    let mut row = vec![0u32; n];
    let mut best = (u32::MAX, 0);
    for (i, a) in descriptors.iter().enumerate() {
        for (j, b) in descriptors.iter().enumerate() {
            row[j] = crate::frontend::features::hamming(a, b);
        }
        row.sort_unstable();
        let median = row[(n - 1) / 2];
        if median < best.0 {
            best = (median, i);
        }
    }
    Some(descriptors[best.1])
}
