//! The built-in scenes: `assets/scenes/NAME.toml`, embedded in the binary.

use super::{Scene, SceneError, load_str};

/// Names and texts, sorted by name.
const SCENES: &[(&str, &str)] = &[
    (
        "ball_and_chain",
        include_str!("../../assets/scenes/ball_and_chain.toml"),
    ),
    (
        "ball_stack",
        include_str!("../../assets/scenes/ball_stack.toml"),
    ),
    ("bounce", include_str!("../../assets/scenes/bounce.toml")),
    ("bridge", include_str!("../../assets/scenes/bridge.toml")),
    ("car", include_str!("../../assets/scenes/car.toml")),
    ("chain", include_str!("../../assets/scenes/chain.toml")),
    (
        "compound",
        include_str!("../../assets/scenes/compound.toml"),
    ),
    (
        "double_pendulum",
        include_str!("../../assets/scenes/double_pendulum.toml"),
    ),
    (
        "friction_ramp",
        include_str!("../../assets/scenes/friction_ramp.toml"),
    ),
    (
        "joint_grid",
        include_str!("../../assets/scenes/joint_grid.toml"),
    ),
    ("joints", include_str!("../../assets/scenes/joints.toml")),
    (
        "large_pyramid",
        include_str!("../../assets/scenes/large_pyramid.toml"),
    ),
    (
        "machines",
        include_str!("../../assets/scenes/machines.toml"),
    ),
    (
        "multi_pendulum",
        include_str!("../../assets/scenes/multi_pendulum.toml"),
    ),
    (
        "newtons_cradle",
        include_str!("../../assets/scenes/newtons_cradle.toml"),
    ),
    (
        "particles",
        include_str!("../../assets/scenes/particles.toml"),
    ),
    (
        "pendulum",
        include_str!("../../assets/scenes/pendulum.toml"),
    ),
    ("pyramid", include_str!("../../assets/scenes/pyramid.toml")),
    (
        "pyramid_throw",
        include_str!("../../assets/scenes/pyramid_throw.toml"),
    ),
    ("ragdoll", include_str!("../../assets/scenes/ragdoll.toml")),
    ("rope", include_str!("../../assets/scenes/rope.toml")),
    (
        "sensor_gate",
        include_str!("../../assets/scenes/sensor_gate.toml"),
    ),
    ("shapes", include_str!("../../assets/scenes/shapes.toml")),
    ("stack", include_str!("../../assets/scenes/stack.toml")),
    (
        "vacuum_vs_fluid",
        include_str!("../../assets/scenes/vacuum_vs_fluid.toml"),
    ),
];

/// Names of the scenes [`builtin`] knows, sorted.
const NAMES: &[&str] = &[
    "ball_and_chain",
    "ball_stack",
    "bounce",
    "bridge",
    "car",
    "chain",
    "compound",
    "double_pendulum",
    "friction_ramp",
    "joint_grid",
    "joints",
    "large_pyramid",
    "machines",
    "multi_pendulum",
    "newtons_cradle",
    "particles",
    "pendulum",
    "pyramid",
    "pyramid_throw",
    "ragdoll",
    "rope",
    "sensor_gate",
    "shapes",
    "stack",
    "vacuum_vs_fluid",
];

/// The names of the built-in scenes, sorted.
pub fn builtin_names() -> &'static [&'static str] {
    NAMES
}

/// The TOML text of a built-in scene.
fn text(name: &str) -> Option<&'static str> {
    SCENES.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// The built-in scene `name`, parsed (its source is `builtin:NAME`); `None` when there
/// is no such built-in scene.
pub fn builtin(name: &str) -> Option<Result<Scene, SceneError>> {
    text(name).map(|t| load_str(t, &format!("builtin:{name}")))
}

/// The `description` of a built-in scene, read without building the scene (cheap,
/// for listings); `None` when there is no such scene or it has no description.
pub fn builtin_description(name: &str) -> Option<String> {
    let t = text(name)?;
    toml::from_str::<super::format::FileDescription>(t)
        .ok()?
        .description
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_match_scenes_and_are_sorted() {
        let names: Vec<&str> = SCENES.iter().map(|(n, _)| *n).collect();
        assert_eq!(names, NAMES);
        let mut sorted = names.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, names);
    }

    #[test]
    fn the_docs_table_lists_every_scene_with_its_description() {
        let doc = include_str!("../../docs/scene-format.md");
        let start = doc.find("## Built-in scenes").expect("section");
        let section = &doc[start..];
        let rows = section.lines().filter(|l| l.starts_with("| `")).count();
        assert_eq!(rows, NAMES.len(), "one row per built-in scene");
        for name in NAMES {
            let d = builtin_description(name).expect("described");
            let row = format!("| `{name}` | {d} |");
            assert!(section.contains(&row), "docs/scene-format.md lacks {row}");
        }
    }
}
