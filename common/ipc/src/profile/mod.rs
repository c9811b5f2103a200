//! Stage profile of a run: the stamps every pose message carries (and the mapper's on
//! its local-map snapshots), gathered per frame by the supervisor's recorder, written as
//! `profile.json`, and summarised as per-stage processing / queueing times and
//! end-to-end latency (`gfsvo profile` prints and plots it).
//!
//! **Model.** One [`FrameRecord`] per frame id: capture time, tracking status, and the
//! [`StageStamp`](crate::StageStamp) of each stage that handled the frame. Headers of the
//! same frame merge: the first stamp of a stage wins, a later header only fills the
//! stages still missing ([`Profile::record`], [`Profile::record_stage`]). Processing is
//! started -> finished, queueing received -> started, end-to-end the source's started
//! to the tracker's finished: frame published to pose out (a keyframe's local mapping
//! follows its pose and shows as the mapper's processing time). Quantiles
//! are nearest-rank ([`Quantiles`]).
//!
//! ```
//! use gfs_core::{ids::FrameId, stamp::Stamp};
//! use gfs_ipc::{MsgHeader, Stage, StageStamp, profile::Profile};
//! let mut profile = Profile::new("lockstep");
//! for k in 0..10u64 {
//!     let mut header = MsgHeader::new(FrameId(k), Stamp::from_nanos(k as i64 * 33_333_333));
//!     let t = 1_000_000_000 * (k + 1);
//!     *header.stamp_mut(Stage::Source) = StageStamp { received_ns: t, started_ns: t, finished_ns: t + 2_000_000 };
//!     *header.stamp_mut(Stage::Tracker) =
//!         StageStamp { received_ns: t + 3_000_000, started_ns: t + 4_000_000, finished_ns: t + (10 + k) * 1_000_000 };
//!     profile.record(&header, "ok");
//! }
//! let summary = profile.summary();
//! assert_eq!(summary.stages[1].processing.median_ms, 10.0); // 6..=15 ms, rank 5
//! assert_eq!(summary.end_to_end.max_ms, 19.0);
//! println!("{summary}");
//! ```

mod io;
mod record;
mod summary;

pub use io::ProfileError;
pub use record::{FrameRecord, Profile, StageTimes};
pub use summary::{ProfileSummary, Quantiles, StageSummary};
