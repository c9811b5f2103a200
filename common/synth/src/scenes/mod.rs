//! The layouts of the built-in scenes.

mod corridor;
mod parts;
mod room;

use crate::scene::{Scene, SceneKind};

/// Builds scene `kind` with texture content drawn from `seed`.
pub(crate) fn build(kind: SceneKind, seed: u64) -> Scene {
    match kind {
        SceneKind::Room => room::textured(seed),
        SceneKind::LowTexture => room::low_texture(seed),
        SceneKind::Corridor => corridor::build(seed),
    }
}
