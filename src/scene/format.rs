//! The scene file as TOML holds it: serde types, every value wrapped in
//! [`Spanned`] so that validation can point at it. Unknown keys are refused
//! everywhere (`deny_unknown_fields`). Nothing here is checked beyond its TOML type;
//! `validate` and `generators` turn these into [`crate::defs`] types.

use serde::Deserialize;
use toml::Spanned;

/// A value and where it is in the text.
pub(crate) type S<T> = Spanned<T>;
/// `[x, y]`: a size, a velocity, a direction.
pub(crate) type V2 = Pair<f32>;
/// `[x, y]`: a point in the world, read as f64 so that a scene far from 0 keeps its
/// precision until the scene's origin is taken off (`validate::Ctx::point`).
pub(crate) type P2 = Pair<f64>;

/// A TOML array of exactly two elements. (serde's `[T; 2]` silently ignores extra
/// elements with toml, so the length is checked here.)
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pair<T>(pub [T; 2]);

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Pair<T> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v: Vec<T> = Vec::deserialize(d)?;
        let n = v.len();
        <[T; 2]>::try_from(v)
            .map(Pair)
            .map_err(|_| serde::de::Error::invalid_length(n, &"an array of 2 elements"))
    }
}

/// The whole file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileScene {
    pub name: S<String>,
    pub description: Option<S<String>>,
    pub world: Option<S<FileWorld>>,
    pub solver: Option<S<FileSolver>>,
    pub camera: Option<S<FileCamera>>,
    #[serde(default)]
    pub body: Vec<S<FileBody>>,
    #[serde(default)]
    pub force: Vec<S<FileForce>>,
    #[serde(default)]
    pub joint: Vec<S<FileJoint>>,
    #[serde(default)]
    pub pyramid: Vec<S<FilePyramid>>,
    #[serde(default)]
    pub stack: Vec<S<FileStack>>,
    #[serde(default)]
    pub grid: Vec<S<FileGrid>>,
    #[serde(default)]
    pub chain: Vec<S<FileChain>>,
    #[serde(default)]
    pub polyline: Vec<S<FilePolyline>>,
    #[serde(default)]
    pub humans: Vec<S<FileHumans>>,
    #[serde(default)]
    pub spawn: Vec<S<FileSpawn>>,
}

/// `[[spawn]]`: a group of bodies and joints added every `every` steps.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileSpawn {
    pub every: S<u64>,
    pub first: Option<S<u64>>,
    pub count: Option<S<u64>>,
    pub keep: Option<S<u64>>,
    pub offset: Option<S<V2>>,
    pub cycle: Option<S<u64>>,
    #[serde(default)]
    pub body: Vec<S<FileBody>>,
    #[serde(default)]
    pub joint: Vec<S<FileJoint>>,
    #[serde(default)]
    pub pyramid: Vec<S<FilePyramid>>,
    #[serde(default)]
    pub stack: Vec<S<FileStack>>,
    #[serde(default)]
    pub grid: Vec<S<FileGrid>>,
    #[serde(default)]
    pub chain: Vec<S<FileChain>>,
    #[serde(default)]
    pub polyline: Vec<S<FilePolyline>>,
    #[serde(default)]
    pub humans: Vec<S<FileHumans>>,
}

/// `[[humans]]`: Box2D's ragdoll ("human"), `count` of them side by side.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileHumans {
    pub origin: Option<S<P2>>,
    pub count: Option<S<u32>>,
    pub spacing: Option<S<V2>>,
    pub scale: Option<S<f32>>,
    pub joint_friction: Option<S<f32>>,
    pub joint_hertz: Option<S<f32>>,
    pub joint_damping_ratio: Option<S<f32>>,
    pub group: Option<S<i64>>,
    pub awake: Option<S<bool>>,
}

/// `[[polyline]]`: terrain, one static (or kinematic) segment body per pair of points.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FilePolyline {
    pub points: S<Vec<S<V2>>>,
    pub origin: Option<S<P2>>,
    #[serde(rename = "type")]
    pub type_: Option<S<String>>,
    pub one_sided: Option<S<bool>>,
    /// Closed: a last segment joins the last point to the first.
    #[serde(rename = "loop")]
    pub loop_: Option<S<bool>>,
    pub friction: Option<S<f32>>,
    pub restitution: Option<S<f32>>,
    pub color: Option<S<String>>,
    pub filter: Option<S<FileFilter>>,
}

/// `[world]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileWorld {
    pub gravity: Option<S<V2>>,
    pub drag: Option<S<FileDrag>>,
}

/// `[world.drag]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileDrag {
    pub linear: Option<S<f32>>,
    pub quadratic: Option<S<f32>>,
    pub fluid_density: Option<S<f32>>,
    pub drag_coefficient: Option<S<f32>>,
}

/// `[solver]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileSolver {
    pub kind: Option<S<String>>,
    pub dt: Option<S<f32>>,
    pub substeps: Option<S<u32>>,
    pub iterations: Option<S<u32>>,
    pub tolerance: Option<S<f32>>,
    pub warm_start: Option<S<bool>>,
    pub baumgarte: Option<S<f32>>,
    pub slop: Option<S<f32>>,
    pub split_impulse: Option<S<bool>>,
    pub block_solve: Option<S<bool>>,
    pub sleep: Option<S<bool>>,
    pub restitution_threshold: Option<S<f32>>,
    pub soft_step: Option<S<bool>>,
    pub contact_hertz: Option<S<f32>>,
    pub contact_damping_ratio: Option<S<f32>>,
    pub max_push_speed: Option<S<f32>>,
    pub joint_hertz: Option<S<f32>>,
    pub joint_damping_ratio: Option<S<f32>>,
}

/// `[camera]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileCamera {
    pub center: Option<S<P2>>,
    pub pixels_per_meter: Option<S<f32>>,
    pub size: Option<S<Pair<u32>>>,
}

/// `shape = { box = [w, h] }` | `{ circle = r }` | `{ polygon = [[x, y], ...] }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileShape {
    #[serde(rename = "box")]
    pub box_: Option<S<V2>>,
    pub circle: Option<S<f32>>,
    pub polygon: Option<S<Vec<S<V2>>>>,
    pub capsule: Option<S<FileCapsule>>,
    pub segment: Option<S<Vec<S<V2>>>>,
    /// Rounds a box's or a polygon's corners.
    pub radius: Option<S<f32>>,
}

/// One part of `shapes = [...]`: a shape's keys, where it sits in the body, and its
/// own material.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FilePart {
    #[serde(rename = "box")]
    pub box_: Option<S<V2>>,
    pub circle: Option<S<f32>>,
    pub polygon: Option<S<Vec<S<V2>>>>,
    pub capsule: Option<S<FileCapsule>>,
    pub segment: Option<S<Vec<S<V2>>>>,
    pub radius: Option<S<f32>>,
    pub offset: Option<S<V2>>,
    pub angle: Option<S<f32>>,
    pub density: Option<S<f32>>,
    pub friction: Option<S<f32>>,
    pub restitution: Option<S<f32>>,
    pub filter: Option<S<FileFilter>>,
    pub sensor: Option<S<bool>>,
}

/// `capsule = { length = L, radius = r }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileCapsule {
    pub length: S<f32>,
    pub radius: S<f32>,
}

/// `[[body]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileBody {
    pub name: Option<S<String>>,
    #[serde(rename = "type")]
    pub type_: Option<S<String>>,
    pub model: Option<S<String>>,
    /// One shape; or `shapes`, the parts of a compound body.
    pub shape: Option<S<FileShape>>,
    pub shapes: Option<S<Vec<S<FilePart>>>>,
    pub position: Option<S<P2>>,
    pub angle: Option<S<f32>>,
    pub velocity: Option<S<V2>>,
    pub angular_velocity: Option<S<f32>>,
    pub density: Option<S<f32>>,
    pub mass: Option<S<f32>>,
    pub friction: Option<S<f32>>,
    pub restitution: Option<S<f32>>,
    pub color: Option<S<String>>,
    pub filter: Option<S<FileFilter>>,
    pub sensor: Option<S<bool>>,
    pub awake: Option<S<bool>>,
    pub linear_damping: Option<S<f32>>,
    pub angular_damping: Option<S<f32>>,
    pub sleep_threshold: Option<S<f32>>,
    pub oscillate: Option<S<FileOscillate>>,
}

/// `oscillate = { amplitude = [x, y], angular_frequency = w, phase = p }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileOscillate {
    pub amplitude: S<V2>,
    pub angular_frequency: S<f32>,
    pub phase: Option<S<f32>>,
}

/// `filter = { category = "debris", mask = ["ground", "debris"], group = -1 }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileFilter {
    pub category: Option<S<String>>,
    pub mask: Option<S<Vec<S<String>>>>,
    pub group: Option<S<i64>>,
}

/// `[[force]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileForce {
    pub body: S<String>,
    pub force: S<V2>,
    pub point: Option<S<P2>>,
}

/// `motor = { speed, max_torque | max_force }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileMotor {
    pub speed: S<f32>,
    pub max_torque: Option<S<f32>>,
    pub max_force: Option<S<f32>>,
}

/// `servo = { target }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileServo {
    pub target: S<f32>,
}

/// `damping = { linear, angular }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileDamping {
    pub linear: Option<S<f32>>,
    pub angular: Option<S<f32>>,
}

/// `[[joint]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileJoint {
    #[serde(rename = "type")]
    pub type_: S<String>,
    pub bodies: S<Pair<S<String>>>,
    pub anchor: Option<S<P2>>,
    pub anchors: Option<S<Pair<S<P2>>>>,
    pub length: Option<S<f32>>,
    pub axis: Option<S<V2>>,
    pub limits: Option<S<V2>>,
    pub motor: Option<S<FileMotor>>,
    pub servo: Option<S<FileServo>>,
    pub compliance: Option<S<f32>>,
    pub damping: Option<S<FileDamping>>,
    pub collide_connected: Option<S<bool>>,
    /// wheel
    pub spring: Option<S<FileSpring>>,
    /// motor joint
    pub offset: Option<S<V2>>,
    pub angle: Option<S<f32>>,
    pub max_force: Option<S<f32>>,
    pub max_torque: Option<S<f32>>,
    pub correction: Option<S<f32>>,
    /// pulley
    pub ground_anchors: Option<S<Pair<S<P2>>>>,
    pub ratio: Option<S<f32>>,
    /// hinge
    pub reference_angle: Option<S<f32>>,
    /// any joint: the force (N) and torque (N m) past which it breaks
    pub break_force: Option<S<f32>>,
    pub break_torque: Option<S<f32>>,
}

/// `spring = { hertz, damping_ratio }` (wheel).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileSpring {
    pub hertz: S<f32>,
    pub damping_ratio: S<f32>,
}

/// `[[pyramid]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FilePyramid {
    pub base: S<u32>,
    #[serde(rename = "box")]
    pub box_: Option<S<V2>>,
    pub origin: Option<S<P2>>,
    pub density: Option<S<f32>>,
    pub friction: Option<S<f32>>,
    pub restitution: Option<S<f32>>,
    pub color: Option<S<String>>,
    pub filter: Option<S<FileFilter>>,
    pub awake: Option<S<bool>>,
}

/// `[[stack]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileStack {
    pub count: S<u32>,
    #[serde(rename = "box")]
    pub box_: Option<S<V2>>,
    pub origin: Option<S<P2>>,
    pub offset: Option<S<f32>>,
    pub density: Option<S<f32>>,
    pub friction: Option<S<f32>>,
    pub restitution: Option<S<f32>>,
    pub color: Option<S<String>>,
    pub filter: Option<S<FileFilter>>,
    pub awake: Option<S<bool>>,
}

/// `[[grid]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileGrid {
    pub rows: S<u32>,
    pub columns: S<u32>,
    pub spacing: S<V2>,
    pub origin: Option<S<P2>>,
    /// One shape for every cell; or `shapes` (a compound's parts), or `shape_cycle`
    /// (cell i takes shape i mod n).
    pub shape: Option<S<FileShape>>,
    pub shapes: Option<S<Vec<S<FilePart>>>>,
    pub shape_cycle: Option<S<Vec<S<FileShape>>>>,
    /// Only the first `count` cells, row by row.
    pub count: Option<S<u32>>,
    #[serde(rename = "type")]
    pub type_: Option<S<String>>,
    pub model: Option<S<String>>,
    pub density: Option<S<f32>>,
    pub mass: Option<S<f32>>,
    pub friction: Option<S<f32>>,
    pub restitution: Option<S<f32>>,
    pub color: Option<S<String>>,
    pub filter: Option<S<FileFilter>>,
    /// `"hinge"`: each body hinged to its left and previous-row neighbours.
    pub joints: Option<S<String>>,
    /// `[[row, column], ...]`: cells made static (anchors).
    pub static_cells: Option<S<Vec<S<Pair<i64>>>>>,
    pub awake: Option<S<bool>>,
}

/// `end = { shape, density | mass, friction, restitution, color }` of a chain.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileChainEnd {
    pub shape: S<FileShape>,
    pub density: Option<S<f32>>,
    pub mass: Option<S<f32>>,
    pub friction: Option<S<f32>>,
    pub restitution: Option<S<f32>>,
    pub color: Option<S<String>>,
}

/// `[[chain]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileChain {
    pub links: S<u32>,
    pub link: S<V2>,
    pub anchor: S<P2>,
    pub direction: Option<S<V2>>,
    pub joint: Option<S<String>>,
    pub density: Option<S<f32>>,
    pub friction: Option<S<f32>>,
    pub restitution: Option<S<f32>>,
    pub color: Option<S<String>>,
    pub filter: Option<S<FileFilter>>,
    pub end: Option<S<FileChainEnd>>,
}

/// Only the description, for listing built-in scenes without building them.
#[derive(Debug, Deserialize)]
pub(crate) struct FileDescription {
    pub description: Option<String>,
}
