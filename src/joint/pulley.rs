//! The pulley: a rope from a ground point to an anchor on each body, the sum
//! length_a + ratio length_b held at its length at most. One row, an inequality: the
//! ropes pull, they do not push.

use super::pgs::{Row, RowBuilder};
use super::soft::{Jac, Pair, Prepared, Sweep};
use super::xpbd::{Start, VelocityPass, move_body};
use super::{Joint, JointFrame, Kind, SLOTS, slot};
use crate::body::Body;
use crate::defs::JointDef;
use crate::math::{Vec2, cross};

/// The pulley's [`Kind`].
pub(super) struct Pulley;

/// A pulley's two ropes: arms, unit directions (ground to anchor) and lengths.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PulleyRopes {
    pub ra: Vec2,
    pub rb: Vec2,
    pub ua: Vec2,
    pub ub: Vec2,
    pub len_a: f32,
    pub len_b: f32,
}

impl PulleyRopes {
    /// From the arms and the vectors ground point to anchor (ea, eb).
    #[inline]
    pub fn new(ra: Vec2, rb: Vec2, ea: Vec2, eb: Vec2) -> PulleyRopes {
        let (len_a, len_b) = (ea.length(), eb.length());
        PulleyRopes {
            ra,
            rb,
            ua: if len_a > 1e-9 { ea / len_a } else { Vec2::Y },
            ub: if len_b > 1e-9 { eb / len_b } else { Vec2::Y },
            len_a,
            len_b,
        }
    }

    /// The soft step's ropes now, from the bodies' motion since the step's start.
    #[inline]
    fn since_start(p: &Prepared, pair: &Pair, g: &JointFrame) -> PulleyRopes {
        let ea = p.ea0 + pair.a.dp + (g.ra - p.ra0);
        let eb = p.eb0 + pair.b.dp + (g.rb - p.rb0);
        PulleyRopes::new(g.ra, g.rb, ea, eb)
    }

    /// The soft step's row: d/dt (length - len_a - r len_b).
    #[inline]
    fn jac(&self, ratio: f32) -> Jac {
        Jac {
            la: -self.ua,
            ka: -cross(self.ra, self.ua),
            lb: -ratio * self.ub,
            kb: -ratio * cross(self.rb, self.ub),
        }
    }
}

impl Joint {
    /// A pulley's ropes now: for each side the unit direction from its ground point to
    /// its anchor and its length, with the world arms (ra, rb).
    #[inline]
    pub(crate) fn pulley_ropes(&self, bodies: &[Body]) -> PulleyRopes {
        let (ba, bb) = (&bodies[self.a], &bodies[self.b]);
        let ra = ba.rot.rotate(self.local_a);
        let rb = bb.rot.rotate(self.local_b);
        PulleyRopes::new(
            ra,
            rb,
            ba.position + ra - self.ground[0],
            bb.position + rb - self.ground[1],
        )
    }
}

impl Kind for Pulley {
    fn reaction(l: &[f32; SLOTS]) -> (f32, f32) {
        (l[slot::AXIAL].abs(), 0.0)
    }

    fn default_anchors(ba: &Body, bb: &Body) -> (Vec2, Vec2) {
        // both centres of mass
        (ba.position, bb.position)
    }

    fn check(def: &JointDef) -> Result<(), String> {
        if def.ground_anchors.is_none() {
            return Err("a pulley needs ground anchors".into());
        }
        if !(def.ratio > 0.0 && def.ratio.is_finite()) {
            return Err(format!("a pulley's ratio must be > 0, got {}", def.ratio));
        }
        Ok(())
    }

    fn init(j: &mut Joint, def: &JointDef, _ends: (&Body, &Body), (wa, wb): (Vec2, Vec2)) {
        let ground = def.ground_anchors.unwrap_or([wa, wb]);
        j.ground = ground;
        j.ratio = def.ratio;
        j.length = def
            .length
            .unwrap_or(wa.distance(ground[0]) + def.ratio * wb.distance(ground[1]));
        (j.servo, j.motor, j.limits) = (None, None, None);
    }

    fn position_error(j: &Joint, _f: &JointFrame, bodies: &[Body]) -> f32 {
        let p = j.pulley_ropes(bodies);
        (p.len_a + j.ratio * p.len_b - j.length).max(0.0)
    }

    fn pgs_rows(j: &Joint, _f: &JointFrame, rows: &mut RowBuilder) {
        let p = j.pulley_ropes(rows.world);
        let c = j.length - p.len_a - j.ratio * p.len_b;
        // J v = d/dt (length - len_a - r len_b) = -(u_a . v_pa + r u_b . v_pb)
        let row = Row::of(
            rows.a,
            rows.b,
            (-p.ua, -cross(p.ra, p.ua)),
            (-j.ratio * p.ub, -j.ratio * cross(p.rb, p.ub)),
        );
        let r = rows.inequality(row, c);
        rows.push(j, r, slot::AXIAL);
    }

    fn project(j: &Joint, bodies: &mut [Body], _t: &Start, _h: f32, _l: &mut [f32; SLOTS]) {
        let p = j.pulley_ropes(bodies);
        let c = p.len_a + j.ratio * p.len_b - j.length;
        if c > 0.0 {
            correction(bodies, j.a, j.b, &p, j.ratio, c);
        }
    }

    fn xpbd_velocity(j: &Joint, _f: &JointFrame, pass: &mut VelocityPass) {
        pass.motor_of(j, Row::angle(pass.a, pass.b));
    }

    fn soft_prepare(j: &Joint, bodies: &[Body], _h: f32, p: &mut Prepared) {
        let (pa, pb) = j.world_anchors(bodies);
        (p.ea0, p.eb0) = (pa - j.ground[0], pb - j.ground[1]);
    }

    fn soft_warm_start(p: &Prepared, j: &Joint, pair: &mut Pair, g: &JointFrame) {
        let ropes = PulleyRopes::since_start(p, pair, g);
        pair.apply(&ropes.jac(j.ratio), p.impulses[slot::AXIAL]);
    }

    fn soft_solve(sw: &Sweep, p: &mut Prepared, j: &Joint, pair: &mut Pair, g: &JointFrame) -> f32 {
        let ropes = PulleyRopes::since_start(p, pair, g);
        let c = j.length - ropes.len_a - j.ratio * ropes.len_b;
        sw.inequality(pair, &ropes.jac(j.ratio), c, &mut p.impulses[slot::AXIAL])
    }
}

/// XPBD correction of a pulley stretched by c > 0 (C = len_a + r len_b - length): each
/// anchor is pulled towards its ground point, b's with the ratio's leverage.
#[inline]
fn correction(bodies: &mut [Body], a: usize, b: usize, p: &PulleyRopes, ratio: f32, c: f32) {
    let (ima, iia) = (bodies[a].inv_mass, bodies[a].inv_inertia);
    let (imb, iib) = (bodies[b].inv_mass, bodies[b].inv_inertia);
    let (rua, rub) = (cross(p.ra, p.ua), cross(p.rb, p.ub));
    let w = ima + iia * rua * rua + ratio * ratio * (imb + iib * rub * rub);
    if w <= 0.0 {
        return;
    }
    // dC/dx_a = u_a, dC/dx_b = r u_b
    let dl = -c / w;
    let (pa, pb) = (dl * p.ua, dl * ratio * p.ub);
    move_body(&mut bodies[a], ima * pa, iia * cross(p.ra, pa));
    move_body(&mut bodies[b], imb * pb, iib * cross(p.rb, pb));
}
