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
    check_total(ctx, who, given.len() as u64 - 1, bodies, g.points.span())?;
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
    for i in 0..n - 1 {
        let shape = ShapeDef::ChainSegment {
            a: points[i],
            b: points[i + 1],
            prev: (i > 0).then(|| points[i - 1]),
            next: (i + 2 < n).then(|| points[i + 2]),
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
    check_total(
        ctx,
        who,
        rows as u64 * columns as u64,
        bodies,
        g.rows.span(),
    )?;
    let spacing = ctx.vec2(who, "spacing", &g.spacing)?;
    let origin = ctx.opt_point(who, "origin", g.origin.as_ref(), Vec2::ZERO)?;
    let body_type = ctx.body_type(who, g.type_.as_ref())?;
    let model = ctx.body_model(who, g.model.as_ref())?;
    let shape = ctx.shape(who, &g.shape)?;
    ctx.shape_fits(
        who,
        model,
        body_type == BodyType::Dynamic,
        &shape,
        g.shape.span(),
    )?;
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
        shape: g.shape.span(),
        mass: g
            .mass
            .as_ref()
            .or(g.density.as_ref())
            .map_or(g.shape.span(), |v| v.span()),
        position: g.spacing.span(),
        ..Places::all(t.span())
    };
    for r in 0..rows {
        for c in 0..columns {
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
                ..dynamic_body(format!("{who}_{i}"), shape.clone(), at, &m)
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
