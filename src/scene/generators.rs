//! Generators: tables that expand into many bodies (and, for chains, joints).
//!
//! Each generated body is named `"{generator}{k}_{i}"`: `k` counts that generator's
//! tables from 0 in file order, `i` counts the bodies within the table from 0. A
//! chain's static anchor is `chain{k}_anchor` and its end body `chain{k}_end`.
//! Generated bodies are dynamic unless said otherwise and take the body defaults.

use glam::Vec2;

use super::format::*;
use super::validate::{Bodies, Ctx, Places, R, check_joint};
use crate::defs::*;

/// The most bodies one scene file may make, declared and generated together; more is
/// surely a typo (and would exhaust memory, or take minutes to build, rather than fail
/// cleanly).
pub const MAX_GENERATED: u64 = 1_000_000;

/// Refuses a generator table that would take the file past [`MAX_GENERATED`] bodies.
fn check_total(
    ctx: &Ctx,
    who: &str,
    total: u64,
    bodies: &Bodies,
    span: std::ops::Range<usize>,
) -> R<()> {
    let before = bodies.defs.len() as u64;
    if total > MAX_GENERATED {
        Err(ctx.err(
            span,
            format!("{who}: would make {total} bodies; at most {MAX_GENERATED} in one file"),
        ))
    } else if before + total > MAX_GENERATED {
        Err(ctx.err(
            span,
            format!(
                "{who}: would make {total} bodies, {} in the file with the {before} before it; at most {MAX_GENERATED} in one file",
                before + total
            ),
        ))
    } else {
        Ok(())
    }
}

/// A generated position, refused when it leaves f32's range: at `step` (the spacing,
/// box or link that multiplies the index) unless that term alone fits, else at `origin`.
#[allow(clippy::too_many_arguments)]
fn position(
    ctx: &Ctx,
    who: &str,
    index: u64,
    origin: Vec2,
    offset: (f64, f64),
    step: (&str, std::ops::Range<usize>),
    origin_span: std::ops::Range<usize>,
) -> R<Vec2> {
    let (x, y) = (origin.x as f64 + offset.0, origin.y as f64 + offset.1);
    let p = Vec2::new(x as f32, y as f32);
    if p.is_finite() {
        return Ok(p);
    }
    let step_fits = (offset.0 as f32).is_finite() && (offset.1 as f32).is_finite();
    let (key, span) = if step_fits {
        ("origin", origin_span)
    } else {
        step
    };
    Err(ctx.err(
        span,
        format!(
            "{who}: body {index} would be at [{x:e}, {y:e}], beyond f32's range (|x| < 3.4e38 m); reduce `{key}`"
        ),
    ))
}

/// A dynamic rigid body with the given material.
fn dynamic_body(
    name: String,
    shape: ShapeDef,
    position: Vec2,
    m: &super::validate::Material,
) -> BodyDef {
    BodyDef {
        name,
        shape,
        position,
        density: m.density,
        mass: m.mass,
        friction: m.friction,
        restitution: m.restitution,
        color: m.color,
        ..BodyDef::default()
    }
}

/// `[[pyramid]]`: row i = 0..base-1 has base-i boxes; box j = i..base-1 of row i is
/// at x = origin.x + (i+1) w/2 + w (j-i) - w base/2, y = origin.y + (2i+1) h/2,
/// row by row from the bottom, left to right (the benchmark's large pyramid).
pub(crate) fn pyramid(
    ctx: &Ctx,
    t: &S<FilePyramid>,
    k: usize,
    categories: &[String],
    bodies: &mut Bodies,
) -> R<()> {
    let who = format!("pyramid{k}");
    let who = who.as_str();
    let p = t.get_ref();
    let base = ctx.count(who, "base", &p.base)?;
    check_total(
        ctx,
        who,
        base as u64 * (base as u64 + 1) / 2,
        bodies,
        p.base.span(),
    )?;
    let size = match &p.box_ {
        Some(b) => ctx.size(who, "box", b)?,
        None => Vec2::ONE,
    };
    let origin = ctx.opt_point(who, "origin", p.origin.as_ref(), Vec2::ZERO)?;
    let m = ctx.material(
        who,
        true,
        p.density.as_ref(),
        None,
        p.friction.as_ref(),
        p.restitution.as_ref(),
        p.color.as_ref(),
    )?;
    let filter = ctx.filter(who, p.filter.as_ref(), categories)?;
    let awake = ctx.awake(who, p.awake.as_ref(), BodyType::Dynamic)?;
    let (w, h, n) = (size.x as f64, size.y as f64, base as f64);
    let shape = ShapeDef::Box {
        width: size.x,
        height: size.y,
    };
    let box_span = p.box_.as_ref().map_or(t.span(), |b| b.span());
    let origin_span = p.origin.as_ref().map_or(t.span(), |v| v.span());
    let places = Places {
        shape: box_span.clone(),
        mass: p.density.as_ref().map_or(box_span.clone(), |v| v.span()),
        position: box_span.clone(),
        ..Places::all(t.span())
    };
    let mut index = 0;
    for i in 0..base {
        let fi = i as f64;
        let y = (2.0 * fi + 1.0) * h / 2.0;
        for j in i..base {
            let x = (fi + 1.0) * w / 2.0 + w * (j - i) as f64 - w * n / 2.0;
            let at = position(
                ctx,
                who,
                index,
                origin,
                (x, y),
                ("box", box_span.clone()),
                origin_span.clone(),
            )?;
            let body = BodyDef {
                filter,
                awake,
                ..dynamic_body(format!("{who}_{index}"), shape.clone(), at, &m)
            };
            bodies.push(ctx, body, t.span(), &places)?;
            index += 1;
        }
    }
    Ok(())
}

/// `[[stack]]`: box k = 0..count-1 at (origin.x + k offset, origin.y + (k + 1/2) h).
pub(crate) fn stack(
    ctx: &Ctx,
    t: &S<FileStack>,
    k: usize,
    categories: &[String],
    bodies: &mut Bodies,
) -> R<()> {
    let who = format!("stack{k}");
    let who = who.as_str();
    let s = t.get_ref();
    let count = ctx.count(who, "count", &s.count)?;
    check_total(ctx, who, count as u64, bodies, s.count.span())?;
    let size = match &s.box_ {
        Some(b) => ctx.size(who, "box", b)?,
        None => Vec2::ONE,
    };
    let origin = ctx.opt_point(who, "origin", s.origin.as_ref(), Vec2::ZERO)?;
    let offset = ctx.opt(s.offset.as_ref(), 0.0, |v| ctx.finite(who, "offset", v))?;
    let m = ctx.material(
        who,
        true,
        s.density.as_ref(),
        None,
        s.friction.as_ref(),
        s.restitution.as_ref(),
        s.color.as_ref(),
    )?;
    let filter = ctx.filter(who, s.filter.as_ref(), categories)?;
    let awake = ctx.awake(who, s.awake.as_ref(), BodyType::Dynamic)?;
    let shape = ShapeDef::Box {
        width: size.x,
        height: size.y,
    };
    let box_span = s.box_.as_ref().map_or(t.span(), |b| b.span());
    let origin_span = s.origin.as_ref().map_or(t.span(), |v| v.span());
    let places = Places {
        shape: box_span.clone(),
        mass: s.density.as_ref().map_or(box_span.clone(), |v| v.span()),
        position: box_span.clone(),
        ..Places::all(t.span())
    };
    for i in 0..count {
        let fi = i as f64;
        let x = fi * offset as f64;
        let y = (fi + 0.5) * size.y as f64;
        // the offset is to blame when x overflows, the box when y does
        let step = if (x as f32).is_finite() {
            ("box", box_span.clone())
        } else {
            ("offset", s.offset.as_ref().map_or(t.span(), |v| v.span()))
        };
        let at = position(
            ctx,
            who,
            i as u64,
            origin,
            (x, y),
            step,
            origin_span.clone(),
        )?;
        let body = BodyDef {
            filter,
            awake,
            ..dynamic_body(format!("{who}_{i}"), shape.clone(), at, &m)
        };
        bodies.push(ctx, body, t.span(), &places)?;
    }
    Ok(())
}

/// `[[polyline]]`: points p0, p1, ... make segment bodies `polyline{k}_{i}` from p_i to
/// p_i+1 (each placed at its midpoint), each knowing its neighbours' far ends so shapes
/// slide across the joints.
pub(crate) fn polyline(
    ctx: &Ctx,
    t: &S<FilePolyline>,
    k: usize,
    categories: &[String],
    bodies: &mut Bodies,
) -> R<()> {
    let who = format!("polyline{k}");
    let who = who.as_str();
    let g = t.get_ref();
    let given = g.points.get_ref();
    if given.len() < 2 {
        return Err(ctx.err(
            g.points.span(),
            format!(
                "{who}: a polyline needs at least 2 points, got {}",
                given.len()
            ),
        ));
    }
    check_total(ctx, who, given.len() as u64, bodies, g.points.span())?;
    let mut points = Vec::with_capacity(given.len());
    for (i, q) in given.iter().enumerate() {
        let p = ctx.vec2(who, "polyline point", q)?;
        if let Some(&last) = points.last()
            && p.distance(last) < 1e-4
        {
            return Err(ctx.err(
                q.span(),
                format!(
                    "{who}: point {i} is {} m from the one before it; consecutive points must be at least 1e-4 m apart",
                    p.distance(last)
                ),
            ));
        }
        points.push(p);
    }
    let origin = ctx.opt_point(who, "origin", g.origin.as_ref(), Vec2::ZERO)?;
    // a polyline is static unless it says otherwise
    let body_type = match &g.type_ {
        None => BodyType::Static,
        Some(v) => match ctx.body_type(who, Some(v))? {
            BodyType::Dynamic => {
                return Err(ctx.err(
                    v.span(),
                    format!("{who}: a polyline has no area, so it must be static or kinematic"),
                ));
            }
            other => other,
        },
    };
    let one_sided = g.one_sided.as_ref().is_some_and(|v| *v.get_ref());
    let closed = g.loop_.as_ref().is_some_and(|v| *v.get_ref());
    if closed {
        let at = g.loop_.as_ref().map_or(t.span(), |v| v.span());
        if points.len() < 3 {
            return Err(ctx.err(
                at,
                format!(
                    "{who}: a loop needs at least 3 points, got {}",
                    points.len()
                ),
            ));
        }
        let gap = points[0].distance(points[points.len() - 1]);
        if gap < 1e-4 {
            return Err(ctx.err(
                at,
                format!(
                    "{who}: a loop closes itself: its last point must not repeat the first (they are {gap} m apart)"
                ),
            ));
        }
    }
    let m = ctx.material(
        who,
        false,
        None,
        None,
        g.friction.as_ref(),
        g.restitution.as_ref(),
        g.color.as_ref(),
    )?;
    let filter = ctx.filter(who, g.filter.as_ref(), categories)?;
    let places = Places::all(g.points.span());
    let n = points.len();
    // a loop's segments wrap around: segment i runs from point i to point i + 1 mod n
    let segments = if closed { n } else { n - 1 };
    let at = |i: usize| points[i % n];
    for i in 0..segments {
        let shape = ShapeDef::ChainSegment {
            a: at(i),
            b: at(i + 1),
            prev: (closed || i > 0).then(|| at(i + n - 1)),
            next: (closed || i + 2 < n).then(|| at(i + 2)),
            one_sided,
        };
        let body = BodyDef {
            body_type,
            filter,
            ..dynamic_body(format!("{who}_{i}"), shape, origin, &m)
        };
        bodies.push(ctx, body, t.span(), &places)?;
    }
    Ok(())
}

/// `[[grid]]`: the body of row r, column c at origin + (c spacing.x, r spacing.y),
/// row by row (r outer), index i = r columns + c.
pub(crate) fn grid(
    ctx: &Ctx,
    t: &S<FileGrid>,
    k: usize,
    categories: &[String],
    bodies: &mut Bodies,
    joints: &mut Vec<JointDef>,
) -> R<()> {
    let who = format!("grid{k}");
    let who = who.as_str();
    let g = t.get_ref();
    let rows = ctx.count(who, "rows", &g.rows)?;
    let columns = ctx.count(who, "columns", &g.columns)?;
    let cells = rows as u64 * columns as u64;
    let count = match &g.count {
        Some(c) => {
            let n = ctx.count(who, "count", c)? as u64;
            if n > cells {
                return Err(ctx.err(
                    c.span(),
                    format!("{who}: count must be at most rows x columns = {cells}, got {n}"),
                ));
            }
            n
        }
        None => cells,
    };
    check_total(ctx, who, count, bodies, g.rows.span())?;
    let spacing = ctx.vec2(who, "spacing", &g.spacing)?;
    let origin = ctx.opt_point(who, "origin", g.origin.as_ref(), Vec2::ZERO)?;
    let body_type = ctx.body_type(who, g.type_.as_ref())?;
    let model = ctx.body_model(who, g.model.as_ref())?;
    // the cells' shapes: one, a compound, or a cycle of shapes
    let (shapes, shape_span) = match (&g.shape, &g.shapes, &g.shape_cycle) {
        (Some(s), None, None) => (vec![ctx.shape(who, s)?], s.span()),
        (None, Some(p), None) => (vec![ctx.parts(who, p, categories)?], p.span()),
        (None, None, Some(c)) => {
            if c.get_ref().is_empty() {
                return Err(ctx.err(
                    c.span(),
                    format!("{who}: shape_cycle needs at least one shape"),
                ));
            }
            let mut list = Vec::new();
            for s in c.get_ref() {
                list.push(ctx.shape(who, s)?);
            }
            (list, c.span())
        }
        (None, None, None) => {
            return Err(ctx.err(
                t.span(),
                format!("{who}: missing field `shape` (or `shapes`, a compound's parts, or `shape_cycle`)"),
            ));
        }
        _ => {
            let span = [
                g.shapes.as_ref().map(|v| v.span()),
                g.shape_cycle.as_ref().map(|v| v.span()),
            ]
            .into_iter()
            .flatten()
            .next()
            .unwrap_or(t.span());
            return Err(ctx.err(
                span,
                format!("{who}: give one of `shape`, `shapes` and `shape_cycle`"),
            ));
        }
    };
    for shape in &shapes {
        ctx.shape_fits(
            who,
            model,
            body_type == BodyType::Dynamic,
            shape,
            shape_span.clone(),
        )?;
    }
    let m = ctx.material(
        who,
        body_type == BodyType::Dynamic,
        g.density.as_ref(),
        g.mass.as_ref(),
        g.friction.as_ref(),
        g.restitution.as_ref(),
        g.color.as_ref(),
    )?;
    let filter = ctx.filter(who, g.filter.as_ref(), categories)?;
    let awake = ctx.awake(who, g.awake.as_ref(), body_type)?;
    let hinged = match &g.joints {
        Some(j) => ctx.choice(who, "joints", j, &[("hinge", true), ("none", false)])?,
        None => false,
    };
    // the static cells, each checked against the grid's size where it is written
    let mut fixed = std::collections::HashSet::new();
    for cell in g.static_cells.iter().flat_map(|v| v.get_ref()) {
        let [r, c] = cell.get_ref().0;
        if !(0..rows as i64).contains(&r) || !(0..columns as i64).contains(&c) {
            return Err(ctx.err(
                cell.span(),
                format!(
                    "{who}: static_cells: [{r}, {c}] is outside the grid (rows 0..{}, columns 0..{})",
                    rows - 1,
                    columns - 1
                ),
            ));
        }
        fixed.insert((r as u32, c as u32));
    }
    let origin_span = g.origin.as_ref().map_or(t.span(), |v| v.span());
    let places = Places {
        shape: shape_span.clone(),
        mass: g
            .mass
            .as_ref()
            .or(g.density.as_ref())
            .map_or(shape_span.clone(), |v| v.span()),
        position: g.spacing.span(),
        ..Places::all(t.span())
    };
    for r in 0..rows {
        for c in 0..columns {
            if r as u64 * columns as u64 + c as u64 >= count {
                break;
            }
            let x = c as f64 * spacing.x as f64;
            let y = r as f64 * spacing.y as f64;
            let i = r as u64 * columns as u64 + c as u64;
            let at = position(
                ctx,
                who,
                i,
                origin,
                (x, y),
                ("spacing", g.spacing.span()),
                origin_span.clone(),
            )?;
            let body = BodyDef {
                body_type: if fixed.contains(&(r, c)) {
                    BodyType::Static
                } else {
                    body_type
                },
                model,
                filter,
                awake,
                ..dynamic_body(
                    format!("{who}_{i}"),
                    shapes[i as usize % shapes.len()].clone(),
                    at,
                    &m,
                )
            };
            let index = bodies.push(ctx, body, t.span(), &places)?;
            if !hinged {
                continue;
            }
            // hinges to the left neighbour and to the one in the row before, each at
            // the midpoint between the two centres
            let mut join = |other: usize, other_at: Vec2| -> R<()> {
                let j = JointDef::hinge(other, index, (other_at + at) / 2.0);
                check_joint(ctx, bodies, who, &j, t.span())?;
                joints.push(j);
                Ok(())
            };
            if c > 0 {
                let left = index - 1;
                join(left, bodies.defs[left].position)?;
            }
            if r > 0 {
                let below = index - columns as usize;
                join(below, bodies.defs[below].position)?;
            }
        }
    }
    Ok(())
}

/// `[[chain]]`: a static anchor body `chain{k}_anchor` (a circle of radius link
/// height / 2 at `anchor`), then `links` boxes of size `link` laid end to end from
/// `anchor` along `direction` (link i centred at anchor + d (i + 1/2) L, turned to
/// d), then the optional end body `chain{k}_end` just past the last link. Hinge
/// joints sit at the shared end points anchor + d i L; distance joints join the
/// centres of consecutive bodies (a zero-length distance joint has no direction), with
/// the length they have at creation. Joints do not collide their bodies.
pub(crate) fn chain(
    ctx: &Ctx,
    t: &S<FileChain>,
    k: usize,
    categories: &[String],
    bodies: &mut Bodies,
    joints: &mut Vec<JointDef>,
) -> R<()> {
    let who = format!("chain{k}");
    let who = who.as_str();
    let c = t.get_ref();
    let links = ctx.count(who, "links", &c.links)?;
    check_total(ctx, who, links as u64 + 2, bodies, c.links.span())?;
    let size = ctx.size(who, "link", &c.link)?;
    let anchor = ctx.point(who, "anchor", &c.anchor)?;
    let d = match &c.direction {
        Some(v) => {
            let d = ctx.vec2(who, "direction", v)?;
            if d.length() <= 1e-6 {
                return Err(ctx.err(
                    v.span(),
                    format!(
                        "{who}: direction must have a non-zero length, got {}",
                        super::validate::fmt_v2(d.into())
                    ),
                ));
            }
            d.normalize()
        }
        None => Vec2::X,
    };
    let kind = match &c.joint {
        Some(j) => ctx.choice(
            who,
            "joint",
            j,
            &[
                ("hinge", JointKind::Hinge),
                ("distance", JointKind::Distance),
            ],
        )?,
        None => JointKind::Hinge,
    };
    let m = ctx.material(
        who,
        true,
        c.density.as_ref(),
        None,
        c.friction.as_ref(),
        c.restitution.as_ref(),
        c.color.as_ref(),
    )?;
    let filter = ctx.filter(who, c.filter.as_ref(), categories)?;
    let end = match &c.end {
        Some(e) => {
            let ew = format!("{who} end");
            let ew = ew.as_str();
            let f = e.get_ref();
            let shape = ctx.shape(ew, &f.shape)?;
            ctx.shape_fits(ew, BodyModel::Rigid, true, &shape, f.shape.span())?;
            let em = ctx.material(
                ew,
                true,
                f.density.as_ref(),
                f.mass.as_ref(),
                f.friction.as_ref(),
                f.restitution.as_ref(),
                f.color.as_ref(),
            )?;
            Some((shape, em))
        }
        None => None,
    };

    let len = size.x;
    let angle = d.y.atan2(d.x);
    let at = |s: f32| anchor + d * s;
    let joint = |a: usize, b: usize, pa: Vec2, pb: Vec2, hinge_at: Vec2| match kind {
        JointKind::Distance => JointDef::distance(a, b, pa, pb),
        _ => JointDef::hinge(a, b, hinge_at),
    };

    let anchor_body = BodyDef {
        name: format!("{who}_anchor"),
        body_type: BodyType::Static,
        shape: ShapeDef::Circle {
            radius: size.y / 2.0,
        },
        position: anchor,
        filter,
        friction: m.friction,
        restitution: m.restitution,
        color: m.color,
        ..BodyDef::default()
    };
    let link_span = c.link.span();
    let places = Places {
        shape: link_span.clone(),
        mass: c.density.as_ref().map_or(link_span.clone(), |v| v.span()),
        position: link_span.clone(),
        ..Places::all(t.span())
    };
    // Link i is centred at anchor + d (i + 1/2) L: the last is the farthest.
    let last = (links as f64 - 0.5) * len as f64;
    position(
        ctx,
        who,
        links as u64 - 1,
        anchor,
        (d.x as f64 * last, d.y as f64 * last),
        ("link", link_span.clone()),
        c.anchor.span(),
    )?;
    let mut prev = bodies.push(ctx, anchor_body, t.span(), &Places::all(c.anchor.span()))?;
    let mut prev_center = anchor;
    let shape = ShapeDef::Box {
        width: size.x,
        height: size.y,
    };
    for i in 0..links {
        let center = at((i as f32 + 0.5) * len);
        let body = BodyDef {
            angle,
            filter,
            ..dynamic_body(format!("{who}_{i}"), shape.clone(), center, &m)
        };
        let index = bodies.push(ctx, body, t.span(), &places)?;
        let j = joint(prev, index, prev_center, center, at(i as f32 * len));
        check_joint(ctx, bodies, who, &j, link_span.clone())?;
        joints.push(j);
        prev = index;
        prev_center = center;
    }
    if let Some((shape, em)) = end {
        // How far the end shape reaches back along -d from its origin (its local x axis is d).
        let back = match &shape {
            ShapeDef::Circle { radius } => *radius,
            ShapeDef::Box { width, .. } => width / 2.0,
            ShapeDef::Polygon { points } => points
                .iter()
                .map(|p| -p.x)
                .fold(f32::NEG_INFINITY, f32::max),
            ShapeDef::Capsule { length, .. } => length / 2.0,
            ShapeDef::RoundedBox { width, .. } => width / 2.0,
            ShapeDef::RoundedPolygon { points, radius } => {
                points
                    .iter()
                    .map(|p| -p.x)
                    .fold(f32::NEG_INFINITY, f32::max)
                    + radius
            }
            ShapeDef::Segment { a, b } | ShapeDef::ChainSegment { a, b, .. } => (-a.x).max(-b.x),
            // a chain's end is one shape (`ctx.shape` makes no compound)
            ShapeDef::Compound { .. } => 0.0,
        };
        let tip = at(links as f32 * len);
        let center = tip + d * back;
        let body = BodyDef {
            angle,
            filter,
            ..dynamic_body(format!("{who}_end"), shape, center, &em)
        };
        let end_span = c.end.as_ref().map_or(t.span(), |e| e.span());
        let f = c.end.as_ref().map(|e| e.get_ref());
        let end_places = Places {
            shape: f.map_or(end_span.clone(), |f| f.shape.span()),
            mass: f
                .and_then(|f| f.mass.as_ref().or(f.density.as_ref()))
                .map_or(end_span.clone(), |v| v.span()),
            position: link_span.clone(),
            ..Places::all(end_span.clone())
        };
        let index = bodies.push(ctx, body, t.span(), &end_places)?;
        let j = joint(prev, index, prev_center, center, tip);
        check_joint(ctx, bodies, who, &j, end_span)?;
        joints.push(j);
    }
    Ok(())
}

/// The bones of a `[[humans]]` ragdoll (Box2D's `shared/human.c` layout), in the order
/// they are made: name, centre of the capsule above the feet (m, at scale 1), capsule
/// length end to end and radius, the bone it hangs from, the hinge's pivot height,
/// limits (as fractions of pi), the share of the joint friction it gets, its linear
/// damping, and the turn of its hinge's zero against the parent (fractions of pi).
struct Bone {
    name: &'static str,
    center: f32,
    length: f32,
    radius: f32,
    parent: Option<usize>,
    pivot: f32,
    limits: [f32; 2],
    friction_scale: f32,
    damping: f32,
    frame: f32,
}

/// Box2D's human: hip, torso, head, legs (lower ones with a foot), arms.
const BONES: [Bone; 11] = [
    Bone {
        name: "hip",
        center: 0.95,
        length: 0.23,
        radius: 0.095,
        parent: None,
        pivot: 0.0,
        limits: [0.0, 0.0],
        friction_scale: 1.0,
        damping: 0.0,
        frame: 0.0,
    },
    Bone {
        name: "torso",
        center: 1.2,
        length: 0.45,
        radius: 0.09,
        parent: Some(0),
        pivot: 1.0,
        limits: [-0.25, 0.0],
        friction_scale: 0.5,
        damping: 0.0,
        frame: 0.0,
    },
    // Box2D's head capsule runs from -0.038 to 0.039 about 1.475: its centre is 0.0005 up
    Bone {
        name: "head",
        center: 1.4755,
        length: 0.227,
        radius: 0.075,
        parent: Some(1),
        pivot: 1.4,
        limits: [-0.3, 0.1],
        friction_scale: 0.25,
        damping: 0.1,
        frame: 0.0,
    },
    Bone {
        name: "upper_left_leg",
        center: 0.775,
        length: 0.37,
        radius: 0.06,
        parent: Some(0),
        pivot: 0.9,
        limits: [-0.05, 0.4],
        friction_scale: 1.0,
        damping: 0.0,
        frame: 0.0,
    },
    // the lower legs' capsule runs from -0.155 to 0.125 about 0.475 (centre 0.015 down),
    // with a foot; their body stays at 0.475
    Bone {
        name: "lower_left_leg",
        center: 0.475,
        length: 0.37,
        radius: 0.045,
        parent: Some(3),
        pivot: 0.625,
        limits: [-0.5, -0.02],
        friction_scale: 0.5,
        damping: 0.0,
        frame: 0.0,
    },
    Bone {
        name: "upper_right_leg",
        center: 0.775,
        length: 0.37,
        radius: 0.06,
        parent: Some(0),
        pivot: 0.9,
        limits: [-0.05, 0.4],
        friction_scale: 1.0,
        damping: 0.0,
        frame: 0.0,
    },
    Bone {
        name: "lower_right_leg",
        center: 0.475,
        length: 0.37,
        radius: 0.045,
        parent: Some(5),
        pivot: 0.625,
        limits: [-0.5, -0.02],
        friction_scale: 0.5,
        damping: 0.0,
        frame: 0.0,
    },
    Bone {
        name: "upper_left_arm",
        center: 1.225,
        length: 0.32,
        radius: 0.035,
        parent: Some(1),
        pivot: 1.35,
        limits: [-0.1, 0.8],
        friction_scale: 0.5,
        damping: 0.0,
        frame: 0.0,
    },
    Bone {
        name: "lower_left_arm",
        center: 0.975,
        length: 0.31,
        radius: 0.03,
        parent: Some(7),
        pivot: 1.1,
        limits: [-0.2, 0.3],
        friction_scale: 0.1,
        damping: 0.1,
        frame: 0.25,
    },
    Bone {
        name: "upper_right_arm",
        center: 1.225,
        length: 0.32,
        radius: 0.035,
        parent: Some(1),
        pivot: 1.35,
        limits: [-0.1, 0.8],
        friction_scale: 0.5,
        damping: 0.0,
        frame: 0.0,
    },
    Bone {
        name: "lower_right_arm",
        center: 0.975,
        length: 0.31,
        radius: 0.03,
        parent: Some(9),
        pivot: 1.1,
        limits: [-0.2, 0.3],
        friction_scale: 0.1,
        damping: 0.1,
        frame: 0.25,
    },
];

/// The filter category every human's bones belong to.
pub(crate) const HUMAN_CATEGORY: &str = "human";

/// `[[humans]]`: `count` ragdolls of Box2D's human layout, the k-th with its feet at
/// origin + k spacing: 11 capsule bodies (the lower legs with a rounded foot) on 10
/// hinges with limits, joint friction (a motor of speed 0 and torque joint_friction x
/// the bone's share x scale) and a torsion spring (joint_hertz, joint_damping_ratio) to
/// the standing pose. Bones are in the category "human" and collide with "default" and
/// "human" bodies, feet with "default" only; human k is in filter group -(group + k), so
/// its own bones never touch. Bodies `humans{t}_{k}_{bone}`.
pub(crate) fn humans(
    ctx: &Ctx,
    t: &S<FileHumans>,
    k: usize,
    categories: &[String],
    bodies: &mut Bodies,
    joints: &mut Vec<JointDef>,
) -> R<()> {
    use std::f32::consts::{FRAC_PI_2, PI};
    let who = format!("humans{k}");
    let who = who.as_str();
    let h = t.get_ref();
    let count = match &h.count {
        Some(c) => ctx.count(who, "count", c)?,
        None => 1,
    };
    check_total(
        ctx,
        who,
        count as u64 * BONES.len() as u64,
        bodies,
        h.count.as_ref().map_or(t.span(), |c| c.span()),
    )?;
    let origin = ctx.opt_point(who, "origin", h.origin.as_ref(), Vec2::ZERO)?;
    let spacing = ctx.opt_vec2(who, "spacing", h.spacing.as_ref(), Vec2::new(0.5, 0.0))?;
    let s = ctx.opt(h.scale.as_ref(), 1.0, |v| ctx.positive(who, "scale", v))?;
    let friction = ctx.opt(h.joint_friction.as_ref(), 0.05, |v| {
        ctx.non_negative(who, "joint_friction", v)
    })?;
    let hertz = ctx.opt(h.joint_hertz.as_ref(), 5.0, |v| {
        ctx.non_negative(who, "joint_hertz", v)
    })?;
    let zeta = ctx.opt(h.joint_damping_ratio.as_ref(), 0.5, |v| {
        ctx.non_negative(who, "joint_damping_ratio", v)
    })?;
    let awake = ctx.awake(who, h.awake.as_ref(), BodyType::Dynamic)?;
    let first_group = match &h.group {
        Some(g) => {
            let v = *g.get_ref();
            if !(1..=i32::MAX as i64 - count as i64).contains(&v) {
                return Err(ctx.err(
                    g.span(),
                    format!(
                        "{who}: group must be an integer from 1 to {} (human k is in filter group -(group + k)), got {v}",
                        i32::MAX as i64 - count as i64
                    ),
                ));
            }
            v as i32
        }
        None => 1,
    };
    let bit = |name: &str| {
        categories
            .iter()
            .position(|c| c == name)
            .map_or(0, |i| 1u32 << i)
    };
    let (human, default) = (bit(HUMAN_CATEGORY), bit("default"));
    let origin_span = h.origin.as_ref().map_or(t.span(), |v| v.span());
    let places = Places {
        shape: h.scale.as_ref().map_or(t.span(), |v| v.span()),
        position: origin_span.clone(),
        ..Places::all(t.span())
    };
    // the foot, in the lower leg's frame (Box2D's points, rounded by 0.015)
    let foot = [
        [-0.03, -0.185],
        [0.11, -0.185],
        [0.11, -0.16],
        [-0.03, -0.14],
    ]
    .map(|[x, y]| Vec2::new(x * s, y * s));
    for i in 0..count {
        let feet = position(
            ctx,
            who,
            i as u64,
            origin,
            (i as f64 * spacing.x as f64, i as f64 * spacing.y as f64),
            ("spacing", h.spacing.as_ref().map_or(t.span(), |v| v.span())),
            origin_span.clone(),
        )?;
        let filter = Filter {
            category: human,
            mask: human | default,
            group: -(first_group + i as i32),
        };
        let foot_filter = Filter {
            mask: default,
            ..filter
        };
        let first = bodies.defs.len();
        for bone in &BONES {
            let capsule = ShapeDef::Capsule {
                length: bone.length * s,
                radius: bone.radius * s,
            };
            let legged = bone.name.starts_with("lower") && bone.name.ends_with("leg");
            // a capsule lies along its body's x axis: the bones stand at 90 degrees,
            // the lower legs at 0 with their capsule turned as a part
            let (shape, angle) = if legged {
                let leg = PartDef {
                    angle: FRAC_PI_2,
                    ..PartDef::new(capsule, Vec2::new(0.0, -0.015 * s))
                };
                let foot = PartDef {
                    friction: Some(0.05),
                    filter: Some(foot_filter),
                    ..PartDef::new(
                        ShapeDef::RoundedPolygon {
                            points: foot.to_vec(),
                            radius: 0.015 * s,
                        },
                        Vec2::ZERO,
                    )
                };
                (
                    ShapeDef::Compound {
                        parts: vec![leg, foot],
                    },
                    0.0,
                )
            } else {
                (capsule, FRAC_PI_2)
            };
            let body = BodyDef {
                name: format!("{who}_{i}_{}", bone.name),
                shape,
                position: feet + Vec2::new(0.0, bone.center * s),
                angle,
                friction: 0.2,
                filter,
                awake,
                linear_damping: bone.damping,
                sleep_threshold: 0.1,
                ..BodyDef::default()
            };
            let index = bodies.push(ctx, body, t.span(), &places)?;
            let Some(parent) = bone.parent else {
                continue;
            };
            let a = first + parent;
            let (pa, pb) = (&bodies.defs[a], &bodies.defs[index]);
            let mut j = JointDef::hinge(a, index, feet + Vec2::new(0.0, bone.pivot * s));
            j.limits = Some([bone.limits[0] * PI, bone.limits[1] * PI]);
            j.angle = Some(pb.angle - pa.angle + bone.frame * PI);
            j.motor = (friction > 0.0).then_some(MotorDef {
                speed: 0.0,
                max_force: bone.friction_scale * friction * s,
            });
            j.spring = (hertz > 0.0).then_some(SpringDef {
                hertz,
                damping_ratio: zeta,
            });
            check_joint(ctx, bodies, who, &j, t.span())?;
            joints.push(j);
        }
    }
    Ok(())
}
