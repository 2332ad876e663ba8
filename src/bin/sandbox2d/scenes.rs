//! `sandbox2d scenes`: the built-in scenes, one line each.

use sandbox2d::scene;

use crate::failure::Failure;

pub fn list_scenes() -> Result<(), Failure> {
    for name in scene::builtin_names() {
        let d = scene::builtin_description(name).unwrap_or_default();
        say!("{name:<16} {d}")?;
    }
    Ok(())
}
