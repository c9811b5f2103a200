//! Typed ids. A bare `usize` never crosses a crate boundary: the newtype says what it indexes.

use serde::{Deserialize, Serialize};

macro_rules! id_type {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
        #[repr(transparent)]
        pub struct $name(pub u64);

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{}", self.0)
            }
        }
    };
}

id_type!(
    /// Index of an input frame in its sequence (0-based, in input order).
    FrameId
);
id_type!(
    /// Id of a keyframe in the map; never reused.
    KeyFrameId
);
id_type!(
    /// Id of a map point; never reused.
    MapPointId
);
id_type!(
    /// Id of a map line; never reused.
    MapLineId
);
id_type!(
    /// Id of a map plane; never reused.
    MapPlaneId
);
