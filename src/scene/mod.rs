//! Scene files: parse, validate and expand a TOML scene into a [`WorldDef`] and a
//! [`CameraDef`].
//!
//! The format is documented, key by key, in `docs/scene-format.md`. In short: a
//! `name`, an optional `description`, `[world]` (gravity, `[world.drag]`),
//! `[solver]`, `[camera]`, `[[body]]`, `[[force]]`, `[[joint]]`, and the generators
//! `[[pyramid]]`, `[[stack]]`, `[[grid]]` and `[[chain]]`.
//!
//! Bodies are created in the order their tables appear in the file, `[[body]]` and
//! generator tables mixed, each generator expanded in place. Forces and joints name
//! bodies; they become indices into that order.
//!
//! A scene that breaks the format is refused with one [`SceneError`] that reads
//! `FILE:LINE:COL: what is wrong`, pointing at the offending value.
//!
//! ```
//! let scene = sandbox2d::scene::load_str(
//!     "name = \"drop\"\n[[body]]\nshape = { circle = 0.5 }\nposition = [0, 3]\n",
//!     "drop.toml",
//! )
//! .unwrap();
//! assert_eq!(scene.world.bodies.len(), 1);
//!
//! let err = sandbox2d::scene::load_str("name = \"x\"\ngravty = [0, -10]\n", "bad.toml").unwrap_err();
//! assert_eq!((err.line(), err.column()), (Some(2), Some(1)));
//! assert!(err.to_string().starts_with("bad.toml:2:1: unknown field `gravty`"));
//! ```

mod builtin;
mod error;
mod format;
mod generators;
mod validate;

use std::path::Path;

pub use builtin::{builtin, builtin_description, builtin_names};
pub use error::{SceneError, escape_controls};
pub use generators::MAX_GENERATED;
pub use validate::{MAX_FRICTION, MAX_ITERATIONS, MAX_POLYGON_POINTS, MAX_SUBSTEPS};

use crate::defs::{CameraDef, JointDef, WorldDef};
use format::FileScene;
use validate::{Bodies, Ctx, MAX_CATEGORIES, R};

/// A parsed and validated scene: a world to build and the camera to look at it with.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The scene's `name`.
    pub name: String,
    /// The scene's `description`, if it has one.
    pub description: Option<String>,
    /// Bodies in creation order (file order, generators expanded in place), forces
    /// and joints with body indices into that order, gravity, drag and solver settings.
    pub world: WorldDef,
    /// The `[camera]` table, with [`CameraDef::default`] values where absent.
    pub camera: CameraDef,
    /// Where the scene came from: the file path as given, or `builtin:NAME`.
    pub source: String,
}

/// Reads, parses and validates the scene file at `path`. Messages name the file as
/// `path` displays.
pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
    use std::io::Read;
    let source = path.display().to_string();
    let cannot = |e: std::io::Error| SceneError::whole_file(&source, format!("cannot read: {e}"));
    // at most one byte past the limit is read: a larger file (or an endless one, such
    // as /dev/zero) is refused before it is held, let alone parsed
    let file = std::fs::File::open(path).map_err(cannot)?;
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        // pointed at where the limit falls (in the text read so far)
        let cut = String::from_utf8_lossy(&bytes[..MAX_FILE_BYTES as usize]);
        let (line, column) = error::line_col(&cut, cut.len());
        return Err(SceneError::at(
            &source,
            line,
            column,
            format!(
                "the file goes on past {} MiB here, the most a scene file may hold (large scenes are made by generators: [[pyramid]], [[grid]], [[stack]], [[chain]])",
                MAX_FILE_BYTES >> 20
            ),
        ));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        let (line, column) = error::line_col(
            &String::from_utf8_lossy(&e.as_bytes()[..e.utf8_error().valid_up_to()]),
            usize::MAX,
        );
        SceneError::at(&source, line, column, "the file is not valid UTF-8 here")
    })?;
    load_str(&text, &source)
}

/// The largest scene file [`load_file`] reads (16 MiB): parsing holds about 70 bytes
/// of memory for each byte of a file of many small tables, so this bounds a load to
/// about a gigabyte.
pub const MAX_FILE_BYTES: u64 = 16 << 20;

/// Loads a built-in scene by name (see [`builtin_names`]), else the file at that path.
/// A built-in name wins over a file of the same name in the working directory; write
/// `./stack` to mean the file.
pub fn load(name_or_path: &str) -> Result<Scene, SceneError> {
    match builtin(name_or_path) {
        Some(scene) => scene,
        None => load_file(Path::new(name_or_path)),
    }
}

/// Parses and validates a scene from its text. `source` names it in messages and
/// becomes [`Scene::source`].
pub fn load_str(text: &str, source: &str) -> Result<Scene, SceneError> {
    let ctx = Ctx {
        file: source,
        text,
        origin: [0.0; 2],
    };
    let file: FileScene = toml::from_str(text).map_err(|e| {
        let message = e.message().trim_end();
        match e.span() {
            Some(span) => ctx.err(span, message.to_owned()),
            // the reader gives no place for a dotted key too deep for it: found here
            None => match deep_key(text) {
                Some(at) => ctx.err(
                    at..at,
                    format!("this key nests more than {TOML_DEPTH} levels deep ({message})"),
                ),
                None => ctx.err(0..0, message.to_owned()),
            },
        }
    })?;
    let ctx = Ctx {
        origin: scene_origin(&file),
        ..ctx
    };
    build(&ctx, file)
}

/// How deep the TOML reader lets keys and values nest.
const TOML_DEPTH: usize = 80;

/// Where the first dotted key of more than [`TOML_DEPTH`] parts (`a.b.c...`) goes past
/// that depth: the byte offset of its part beyond the limit. Comments and strings are
/// skipped; a part is a bare key or a quoted one.
fn deep_key(text: &str) -> Option<usize> {
    let b = text.as_bytes();
    let bare = |c: u8| c.is_ascii_alphanumeric() || c == b'_' || c == b'-';
    // the end of the quoted string starting at i (past its closing quote)
    let quoted = |i: usize| {
        let q = b[i];
        let mut j = i + 1;
        while j < b.len() && b[j] != q && b[j] != b'\n' {
            j += if b[j] == b'\\' && q == b'"' { 2 } else { 1 };
        }
        (j + 1).min(b.len())
    };
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'#' => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            b'"' | b'\'' | b'_' | b'-' | b'0'..=b'9' | b'a'..=b'z' | b'A'..=b'Z' => {
                // a chain of parts joined by dots
                let mut parts = 0;
                let mut j = i;
                loop {
                    let start = j;
                    j = if b[j] == b'"' || b[j] == b'\'' {
                        quoted(j)
                    } else {
                        let mut k = j;
                        while k < b.len() && bare(b[k]) {
                            k += 1;
                        }
                        k
                    };
                    parts += 1;
                    if parts > TOML_DEPTH {
                        return Some(start);
                    }
                    let mut k = j;
                    while k < b.len() && (b[k] == b' ' || b[k] == b'\t') {
                        k += 1;
                    }
                    if k >= b.len() || b[k] != b'.' {
                        break;
                    }
                    k += 1;
                    while k < b.len() && (b[k] == b' ' || b[k] == b'\t') {
                        k += 1;
                    }
                    if k >= b.len() || !(bare(b[k]) || b[k] == b'"' || b[k] == b'\'') {
                        break;
                    }
                    j = k;
                }
                i = j.max(i + 1);
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    None
}

/// A scene whose placed points (body positions, generator origins, chain anchors) reach
/// beyond this (m) on either axis is simulated relative to an origin of its own.
pub const ORIGIN_SHIFT_BEYOND: f64 = 1000.0;

/// The scene's origin ([`WorldDef::origin`]): (0, 0), or for a scene placed beyond
/// [`ORIGIN_SHIFT_BEYOND`] the centre of its placed points' bounding box, rounded to
/// whole metres (so a scene moved by whole metres keeps the same f32 numbers).
fn scene_origin(f: &FileScene) -> [f64; 2] {
    let points = f
        .body
        .iter()
        .filter_map(|b| b.get_ref().position.as_ref())
        .chain(f.pyramid.iter().filter_map(|g| g.get_ref().origin.as_ref()))
        .chain(f.stack.iter().filter_map(|g| g.get_ref().origin.as_ref()))
        .chain(f.grid.iter().filter_map(|g| g.get_ref().origin.as_ref()))
        .chain(f.chain.iter().map(|g| &g.get_ref().anchor))
        .map(|p| p.get_ref().0)
        // a point beyond f32 is refused where it is written; it must not move the
        // origin (which would push every other point, the camera's too, out of range)
        .filter(|p| p.iter().all(|x| x.abs() <= f32::MAX as f64));
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    let mut far = false;
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
            far |= p[k].abs() > ORIGIN_SHIFT_BEYOND;
        }
    }
    if !far {
        return [0.0; 2];
    }
    // the midpoint, rounded; a span too wide for f64 leaves the origin at 0
    let mid = [0, 1].map(|k| (0.5 * lo[k] + 0.5 * hi[k]).round());
    if mid.iter().all(|x| x.is_finite()) {
        mid
    } else {
        [0.0; 2]
    }
}

/// The tables that make bodies and joints: the whole file's, or one `[[spawn]]`'s.
struct Tables<'a> {
    body: &'a [format::S<format::FileBody>],
    joint: &'a [format::S<format::FileJoint>],
    pyramid: &'a [format::S<format::FilePyramid>],
    stack: &'a [format::S<format::FileStack>],
    grid: &'a [format::S<format::FileGrid>],
    chain: &'a [format::S<format::FileChain>],
    polyline: &'a [format::S<format::FilePolyline>],
    humans: &'a [format::S<format::FileHumans>],
}

impl<'a> Tables<'a> {
    fn of_scene(f: &'a FileScene) -> Tables<'a> {
        Tables {
            body: &f.body,
            joint: &f.joint,
            pyramid: &f.pyramid,
            stack: &f.stack,
            grid: &f.grid,
            chain: &f.chain,
            polyline: &f.polyline,
            humans: &f.humans,
        }
    }

    fn of_spawn(f: &'a format::FileSpawn) -> Tables<'a> {
        Tables {
            body: &f.body,
            joint: &f.joint,
            pyramid: &f.pyramid,
            stack: &f.stack,
            grid: &f.grid,
            chain: &f.chain,
            polyline: &f.polyline,
            humans: &f.humans,
        }
    }

    /// The tables that make bodies, in file order: an array-of-tables element's span
    /// starts at its `[[...]]` header (or at its inline table).
    fn makers(&self) -> Vec<(usize, Maker)> {
        let mut makers: Vec<(usize, Maker)> = Vec::new();
        let mut add = |spans: Vec<usize>, make: fn(usize) -> Maker| {
            makers.extend(spans.into_iter().enumerate().map(|(k, at)| (at, make(k))));
        };
        add(
            self.body.iter().map(|t| t.span().start).collect(),
            Maker::Body,
        );
        add(
            self.pyramid.iter().map(|t| t.span().start).collect(),
            Maker::Pyramid,
        );
        add(
            self.stack.iter().map(|t| t.span().start).collect(),
            Maker::Stack,
        );
        add(
            self.grid.iter().map(|t| t.span().start).collect(),
            Maker::Grid,
        );
        add(
            self.chain.iter().map(|t| t.span().start).collect(),
            Maker::Chain,
        );
        add(
            self.polyline.iter().map(|t| t.span().start).collect(),
            Maker::Polyline,
        );
        add(
            self.humans.iter().map(|t| t.span().start).collect(),
            Maker::Humans,
        );
        makers.sort_by_key(|(start, _)| *start);
        makers
    }

    /// Every filter the tables give (a body's, then its parts'), in file order.
    fn filters(&self) -> Vec<&'a format::S<format::FileFilter>> {
        let mut out = Vec::new();
        for (_, maker) in self.makers() {
            match maker {
                Maker::Body(k) => {
                    let b = self.body[k].get_ref();
                    let parts = b
                        .shapes
                        .as_ref()
                        .map_or(&[][..], |p| p.get_ref().as_slice());
                    out.extend(
                        b.filter
                            .iter()
                            .chain(parts.iter().filter_map(|p| p.get_ref().filter.as_ref())),
                    );
                }
                Maker::Pyramid(k) => out.extend(self.pyramid[k].get_ref().filter.iter()),
                Maker::Stack(k) => out.extend(self.stack[k].get_ref().filter.iter()),
                Maker::Grid(k) => out.extend(self.grid[k].get_ref().filter.iter()),
                Maker::Chain(k) => out.extend(self.chain[k].get_ref().filter.iter()),
                Maker::Polyline(k) => out.extend(self.polyline[k].get_ref().filter.iter()),
                Maker::Humans(_) => {}
            }
        }
        out
    }

    /// Makes the bodies (into `bodies`) and joints of these tables; the motions of the
    /// kinematic bodies that `oscillate`. `no_hash`: body names may not hold a '#'
    /// (the scene spawns copies named `NAME#k`).
    fn make(
        &self,
        ctx: &Ctx,
        categories: &[String],
        bodies: &mut Bodies,
        no_hash: bool,
    ) -> R<(Vec<JointDef>, Vec<crate::defs::MotionDef>)> {
        // Joints with the file position of the table that made them, to keep file order.
        let mut joints: Vec<(usize, JointDef)> = Vec::new();
        let mut motions = Vec::new();
        for (start, maker) in self.makers() {
            let before = bodies.defs.len();
            match maker {
                Maker::Body(k) => {
                    let t = &self.body[k];
                    let (name, span) = match &t.get_ref().name {
                        Some(n) => (n.get_ref().clone(), n.span()),
                        // An unnamed body is named after its table, like generated bodies.
                        None => (format!("body{k}"), t.span()),
                    };
                    if name.is_empty() {
                        return Err(ctx.err(span, "body name must not be empty"));
                    }
                    let body = ctx.body(t.get_ref(), name, categories, t.span())?;
                    let b = t.get_ref();
                    let at = |v: Option<std::ops::Range<usize>>| v.unwrap_or(t.span());
                    let shape_span = b
                        .shape
                        .as_ref()
                        .map(|s| s.span())
                        .or(b.shapes.as_ref().map(|s| s.span()))
                        .unwrap_or(t.span());
                    let places = validate::Places {
                        shape: shape_span.clone(),
                        mass: b
                            .mass
                            .as_ref()
                            .or(b.density.as_ref())
                            .map_or(shape_span, |v| v.span()),
                        position: at(b.position.as_ref().map(|v| v.span())),
                        velocity: at(b.velocity.as_ref().map(|v| v.span())),
                        angular_velocity: at(b.angular_velocity.as_ref().map(|v| v.span())),
                    };
                    let body_type = body.body_type;
                    let index = bodies.push(ctx, body, span, &places)?;
                    if let Some(o) = &b.oscillate {
                        let who = format!("body {:?}", bodies.defs[index].name);
                        motions.push(ctx.oscillate(&who, o, index, body_type)?);
                    }
                }
                Maker::Pyramid(k) => {
                    generators::pyramid(ctx, &self.pyramid[k], k, categories, bodies)?
                }
                Maker::Stack(k) => generators::stack(ctx, &self.stack[k], k, categories, bodies)?,
                Maker::Grid(k) => {
                    let mut made = Vec::new();
                    generators::grid(ctx, &self.grid[k], k, categories, bodies, &mut made)?;
                    joints.extend(made.into_iter().map(|j| (start, j)));
                }
                Maker::Polyline(k) => {
                    generators::polyline(ctx, &self.polyline[k], k, categories, bodies)?
                }
                Maker::Chain(k) => {
                    let mut made = Vec::new();
                    generators::chain(ctx, &self.chain[k], k, categories, bodies, &mut made)?;
                    joints.extend(made.into_iter().map(|j| (start, j)));
                }
                Maker::Humans(k) => {
                    let mut made = Vec::new();
                    generators::humans(ctx, &self.humans[k], k, categories, bodies, &mut made)?;
                    joints.extend(made.into_iter().map(|j| (start, j)));
                }
            }
            if no_hash
                && let Some(i) =
                    (before..bodies.defs.len()).find(|&i| bodies.defs[i].name.contains('#'))
            {
                return Err(ctx.err(
                    bodies.spans[i].clone(),
                    format!(
                        "body name {:?}: a scene with [[spawn]] tables names its spawned copies NAME#k, so its own body names cannot hold a '#'",
                        bodies.defs[i].name
                    ),
                ));
            }
        }
        for t in self.joint {
            joints.push((t.span().start, validate::joint(ctx, bodies, t.get_ref())?));
        }
        // Stable: a chain's joints keep their order.
        joints.sort_by_key(|(start, _)| *start);
        Ok((joints.into_iter().map(|(_, j)| j).collect(), motions))
    }
}

/// One table that makes bodies, by its position in its list.
#[derive(Clone, Copy)]
enum Maker {
    Body(usize),
    Pyramid(usize),
    Stack(usize),
    Grid(usize),
    Chain(usize),
    Polyline(usize),
    Humans(usize),
}

/// Turns the parsed file into a [`Scene`], checking every value.
fn build(ctx: &Ctx, f: FileScene) -> R<Scene> {
    let name = f.name.get_ref().trim().to_owned();
    if name.is_empty() {
        return Err(ctx.err(f.name.span(), "name must not be empty"));
    }
    let mut world = WorldDef {
        origin: glam::DVec2::from(ctx.origin),
        ..WorldDef::default()
    };
    if let Some(w) = &f.world {
        (world.gravity, world.drag) = ctx.world(w.get_ref())?;
    }
    if let Some(s) = &f.solver {
        world.solver = ctx.solver(s.get_ref())?;
    }
    let camera = match &f.camera {
        Some(c) => ctx.camera(c.get_ref())?,
        None => CameraDef::default(),
    };

    let scene = Tables::of_scene(&f);
    let spawns: Vec<Tables> = f
        .spawn
        .iter()
        .map(|s| Tables::of_spawn(s.get_ref()))
        .collect();

    // Filter categories by name, in file order: "default" (every body without one)
    // first, then the scene's, then the spawn tables'; "human" where humans are made.
    let mut categories = vec!["default".to_string()];
    let mut named: Vec<(usize, &String)> = Vec::new();
    for t in std::iter::once(&scene).chain(&spawns) {
        for x in t.filters() {
            if let Some(c) = x.get_ref().category.as_ref() {
                named.push((c.span().start, c.get_ref()));
            }
        }
    }
    let human = generators::HUMAN_CATEGORY.to_string();
    let first_humans = std::iter::once(&scene)
        .chain(&spawns)
        .flat_map(|t| t.humans.iter().map(|h| h.span().start))
        .min();
    if let Some(at) = first_humans {
        named.push((at, &human));
    }
    named.sort_by_key(|(at, _)| *at);
    for (at, c) in named {
        if !categories.contains(c) {
            if categories.len() == MAX_CATEGORIES {
                return Err(ctx.err(
                    at..at,
                    format!(
                        "filter category {c:?}: a scene has at most {MAX_CATEGORIES} \
                         category names (with \"default\")"
                    ),
                ));
            }
            categories.push(c.clone());
        }
    }

    let no_hash = !f.spawn.is_empty();
    let mut bodies = Bodies {
        gravity: world.gravity,
        ..Bodies::default()
    };
    let (joints, motions) = scene.make(ctx, &categories, &mut bodies, no_hash)?;

    // what the bodies' overlap would cost before anything is allocated for it
    if let Err((_, b)) =
        crate::world::count_start_pairs(&bodies.boxes, &bodies.dynamic, &bodies.filters)
    {
        let n = bodies.defs.len();
        return Err(ctx.err(
            bodies.spans[b].clone(),
            format!(
                "body {:?}: the bodies' boxes overlap in more than {} pairs at the start, the most a scene of {n} bodies may have ({} a body, at least {}; each pair costs about 1 KB of memory): spread the bodies apart, or filter apart those that never touch",
                bodies.defs[b].name,
                crate::world::max_start_pairs(n),
                crate::world::START_PAIRS_PER_BODY,
                crate::world::START_PAIRS_FLOOR,
            ),
        ));
    }
    for t in &f.force {
        world
            .forces
            .push(validate::force(ctx, &bodies, t.get_ref())?);
    }
    world.joints = joints;
    world.motions = motions;
    world.bodies = bodies.defs;

    for (k, (t, tables)) in f.spawn.iter().zip(&spawns).enumerate() {
        world
            .spawns
            .push(spawn(ctx, t, tables, k, &categories, world.gravity)?);
    }

    Ok(Scene {
        name,
        description: f.description.map(|d| d.into_inner()),
        world,
        camera,
        source: ctx.file.to_owned(),
    })
}

/// A `[[spawn]]` table: its timing, and its group built as the scene's bodies are (names
/// checked within the group, joints naming the group's bodies only).
fn spawn(
    ctx: &Ctx,
    t: &format::S<format::FileSpawn>,
    tables: &Tables,
    k: usize,
    categories: &[String],
    gravity: Option<glam::Vec2>,
) -> R<crate::defs::SpawnDef> {
    let who = format!("spawn{k}");
    let s = t.get_ref();
    let at_least_one = |key: &str, v: &format::S<u64>| -> R<u64> {
        let n = *v.get_ref();
        if n >= 1 {
            Ok(n)
        } else {
            Err(ctx.err(v.span(), format!("{who}: {key} must be >= 1, got {n}")))
        }
    };
    let every = at_least_one("every", &s.every)?;
    let first = s.first.as_ref().map_or(0, |v| *v.get_ref());
    let count = s
        .count
        .as_ref()
        .map(|v| at_least_one("count", v))
        .transpose()?;
    let keep = s
        .keep
        .as_ref()
        .map(|v| at_least_one("keep", v))
        .transpose()?;
    let cycle = s
        .cycle
        .as_ref()
        .map(|v| at_least_one("cycle", v))
        .transpose()?;
    let offset = ctx.opt_vec2(&who, "offset", s.offset.as_ref(), glam::Vec2::ZERO)?;
    let mut bodies = Bodies {
        gravity,
        ..Bodies::default()
    };
    let (joints, motions) = tables.make(ctx, categories, &mut bodies, true)?;
    if let Some(m) = motions.first() {
        let span = tables
            .body
            .iter()
            .filter_map(|b| b.get_ref().oscillate.as_ref())
            .map(|o| o.span())
            .next()
            .unwrap_or(t.span());
        return Err(ctx.err(
            span,
            format!(
                "{who}: body {:?}: a spawned body cannot follow a path (`oscillate`)",
                bodies.defs[m.body].name
            ),
        ));
    }
    if bodies.defs.is_empty() {
        return Err(ctx.err(
            t.span(),
            format!("{who}: a spawn table makes no body; give it [[spawn.body]], [[spawn.humans]] or another generator"),
        ));
    }
    let mut def = crate::defs::SpawnDef {
        name: who.clone(),
        every,
        first,
        count,
        keep,
        offset,
        cycle,
        bodies: bodies.defs,
        joints,
    };
    for b in &mut def.bodies {
        b.name = format!("{who}/{}", b.name);
    }
    // the farthest copy that will be made, where the copies are bounded
    let last = match (count, cycle) {
        (Some(n), Some(c)) => Some(n.min(c) - 1),
        (Some(n), None) => Some(n - 1),
        (None, Some(c)) => Some(c - 1),
        (None, None) => None,
    };
    if let Some(last) = last {
        let off = def.offset_of(last);
        for (i, b) in def.bodies.iter().enumerate() {
            let p = b.position + off;
            if !p.is_finite() {
                let span = s
                    .offset
                    .as_ref()
                    .map_or(tables_span(&bodies.spans, i, t), |v| v.span());
                return Err(ctx.err(
                    span,
                    format!(
                        "{who}: copy {last} would put body {:?} at {:?}, beyond f32's range; reduce `offset`",
                        b.name, p
                    ),
                ));
            }
        }
    }
    Ok(def)
}

/// Where the group's body `i` was declared (the spawn table when unknown).
fn tables_span(
    spans: &[std::ops::Range<usize>],
    i: usize,
    t: &format::S<format::FileSpawn>,
) -> std::ops::Range<usize> {
    spans.get(i).cloned().unwrap_or(t.span())
}
