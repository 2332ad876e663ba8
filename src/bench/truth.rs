//! The true motion a run is compared with, body by body (`--metric trajectory`).
//!
//! A scene whose motion has a closed form is compared with it ([`Exact`]): bodies in
//! flight under gravity and linear drag, or falling from rest under quadratic drag; a
//! point mass on a rigid rod (the pendulum, at any amplitude: Jacobi's elliptic
//! functions); a mass on a spring; a disk rolling (or sliding) down a ramp from rest; a
//! box sliding on flat ground until friction stops it. [`Exact::of`] reads the scene
//! (a built world) and recognises these layouts only when nothing else can act
//! (no other body in reach, no motor, damping or drive), so the closed form is the
//! scene's own motion and its numbers are the scene's.
//!
//! Any other scene is compared with a reference run ([`Reference`]): the same scene at
//! a much finer step with its solves converged ([`RefSpec`], chosen per scene and
//! stated in the report). The reference's own error is estimated from a second run at
//! twice its step; where the two disagree by more than [`Reference::TRUSTED`] allows,
//! the motion is chaotic (or the solves do not settle) over the horizon and the scene
//! is not measured ([`Truth::Unmeasured`] says why).
//!
//! [`Tracker`] accumulates a run's error against either: the RMS and the worst of the
//! position error (m) and the angle error (rad) over every step of the horizon and
//! every body that started dynamic.

use glam::DVec2;

use crate::body::Body;
use crate::defs::{BodyType, JointKind, SolverKind, SolverOverrides, SolverSettings, WorldDef};
use crate::shape::Shape;
use crate::world::World;

/// A body's place and angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// The centre of mass (m, the file's coordinates).
    pub p: DVec2,
    /// rad, counter-clockwise, not wrapped.
    pub angle: f64,
}

/// The complete elliptic integral of the first kind K(m), m = k^2 < 1, by the
/// arithmetic-geometric mean: K = pi / (2 agm(1, sqrt(1 - m))).
pub fn elliptic_k(m: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (1.0 - m).sqrt());
    for _ in 0..64 {
        if (a - b).abs() <= 1e-16 * a {
            break;
        }
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    std::f64::consts::PI / (2.0 * a)
}

/// Jacobi's sn(u | m) for 0 <= m < 1, by the descending Landen transformation (the AGM
/// scale, Abramowitz and Stegun 16.4).
pub fn jacobi_sn(u: f64, m: f64) -> f64 {
    if m < 1e-15 {
        return u.sin();
    }
    let mut a = vec![1.0f64];
    let mut c = vec![m.sqrt()];
    let mut b = (1.0 - m).sqrt();
    while c.len() < 64 && c[c.len() - 1].abs() > 1e-16 {
        let (an, bn) = (a[a.len() - 1], b);
        a.push(0.5 * (an + bn));
        c.push(0.5 * (an - bn));
        b = (an * bn).sqrt();
    }
    let n = a.len() - 1;
    let mut phi = 2f64.powi(n as i32) * a[n] * u;
    for i in (1..=n).rev() {
        phi = 0.5 * (phi + (c[i] / a[i] * phi.sin()).asin());
    }
    phi.sin()
}

/// ln cosh(x) without overflow.
fn ln_cosh(x: f64) -> f64 {
    let x = x.abs();
    x + (-2.0 * x).exp().ln_1p() - std::f64::consts::LN_2
}

/// A closed form of a scene's motion.
#[derive(Clone, Debug, PartialEq)]
pub enum Exact {
    /// Bodies in flight, none touching another: gravity `g` and a linear drag per
    /// body (F = -c v, `rate` = c / m, 1/s); each turns at its own constant rate.
    Flight { g: DVec2, bodies: Vec<Flying> },
    /// Bodies falling from rest (or along gravity) under quadratic drag F = -k |v| v,
    /// `rate` = k / m (1/m): along gravity, s(t) = (u^2 / g) ln cosh(g t / u + c).
    QuadraticFall { g: DVec2, bodies: Vec<Flying> },
    /// A point mass on a rigid rod of `length` from `pivot`, released from rest at
    /// `theta0` from straight down (the rod's joint at its centre: it does not turn).
    Pendulum {
        body: usize,
        pivot: DVec2,
        length: f64,
        theta0: f64,
        g: DVec2,
        angle: f64,
    },
    /// A mass on a spring (a distance joint of compliance 1/k from `anchor`), moving
    /// along the spring's line: x'' = -(k/m)(x - rest) + g.u.
    Spring {
        body: usize,
        anchor: DVec2,
        dir: DVec2,
        rest_eq: f64,
        x0: f64,
        v0: f64,
        omega: f64,
        angle: f64,
    },
    /// A disk of radius `r` from rest on a ramp: rolling without slipping when friction
    /// holds it (a = g sin / (1 + I / (m r^2))), else sliding (a = g (sin - mu cos)) and
    /// spun up by friction; `spin` is the angular acceleration's sign-carrying value.
    Disk {
        body: usize,
        p0: DVec2,
        down: DVec2,
        accel: f64,
        spin: f64,
        rolling: bool,
        angle: f64,
        /// Until when the disk is on the ramp's face (s).
        until: f64,
    },
    /// A box sliding on flat ground from speed `v0` along `dir`: friction stops it in
    /// v0 / (mu g) (then it rests).
    Slide {
        body: usize,
        p0: DVec2,
        dir: DVec2,
        v0: f64,
        decel: f64,
        angle: f64,
    },
}

/// A body of [`Exact::Flight`] or [`Exact::QuadraticFall`]: its start and drag rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flying {
    pub body: usize,
    pub p0: DVec2,
    pub v0: DVec2,
    pub angle0: f64,
    pub omega: f64,
    pub rate: f64,
}

fn dv(v: glam::Vec2) -> DVec2 {
    v.as_dvec2()
}

/// The dynamic bodies' indices.
fn dynamic(w: &World) -> Vec<usize> {
    w.bodies
        .iter()
        .enumerate()
        .filter(|(_, b)| b.body_type == BodyType::Dynamic)
        .map(|(i, _)| i)
        .collect()
}

fn at_rest(b: &Body) -> bool {
    b.velocity == glam::Vec2::ZERO && b.angular_velocity == 0.0
}

/// The turn of `v` by +90 degrees.
fn perp(v: DVec2) -> DVec2 {
    DVec2::new(-v.y, v.x)
}

impl Exact {
    /// The closed form of the motion of the world as it is now (a scene just built),
    /// or why it has none. `horizon` (s): how long it must hold (a disk must stay on its
    /// ramp, a spring must not fold through its anchor).
    pub fn of(w: &World, horizon: f64) -> Result<Exact, String> {
        let movers = dynamic(w);
        if movers.is_empty() {
            return Err("nothing moves".into());
        }
        if w.force_count() > 0 {
            return Err("the scene has point forces".into());
        }
        let kinematic = w.bodies.iter().any(|b| b.body_type == BodyType::Kinematic);
        if kinematic {
            return Err("the scene has kinematic bodies".into());
        }
        let g = dv(w.gravity.unwrap_or(glam::Vec2::ZERO));
        let statics = w.bodies.len() - movers.len();
        if w.joints.is_empty() && statics == 0 {
            return Self::flight(w, &movers, g);
        }
        if w.joints.len() == 1 && movers.len() == 1 && statics == 1 && w.drag.is_none() {
            let j = &w.joints[0];
            let body = movers[0];
            let other = if j.a == body { j.b } else { j.a };
            let local = if j.a == body { j.local_a } else { j.local_b };
            let plain = j.kind == JointKind::Distance
                && j.limits.is_none()
                && j.motor.is_none()
                && j.servo.is_none()
                && j.damping == Default::default()
                && j.drive == 0.0
                && local == glam::Vec2::ZERO
                && !j.collide_connected;
            if !plain {
                return Err("its joint is not a plain distance joint at the body's centre".into());
            }
            let anchor_local = if j.a == body { j.local_b } else { j.local_a };
            let pivot =
                w.world_position_index(other) + dv(w.bodies[other].rot.rotate(anchor_local));
            let b = &w.bodies[body];
            let p0 = w.world_position_index(body);
            if j.compliance > 0.0 {
                return Self::spring(
                    w,
                    body,
                    pivot,
                    j.length as f64,
                    j.compliance as f64,
                    g,
                    horizon,
                );
            }
            if !at_rest(b) {
                return Err("the pendulum does not start at rest".into());
            }
            if g.length() == 0.0 {
                return Err("no gravity".into());
            }
            let down = g.normalize();
            let d = p0 - pivot;
            let theta0 = d.dot(perp(down)).atan2(d.dot(down));
            if !(theta0.abs() < std::f64::consts::PI - 1e-3) || d.length() < 1e-6 {
                return Err("the pendulum starts upside down".into());
            }
            return Ok(Exact::Pendulum {
                body,
                pivot,
                length: d.length(),
                theta0,
                g,
                angle: b.angle as f64,
            });
        }
        if w.joints.is_empty() && movers.len() == 1 && statics == 1 && w.drag.is_none() {
            let body = movers[0];
            let ground = (0..w.bodies.len())
                .find(|&i| i != body)
                .expect("two bodies");
            return match w.bodies[body].shape {
                Shape::Circle { radius } => Self::disk(w, body, ground, radius as f64, g, horizon),
                Shape::Polygon(_) => Self::slide(w, body, ground, g),
                _ => Err("a body of another shape".into()),
            };
        }
        Err("no closed form for this layout".into())
    }

    fn flight(w: &World, movers: &[usize], g: DVec2) -> Result<Exact, String> {
        let fly = |i: usize, rate: f64| {
            let b = &w.bodies[i];
            Flying {
                body: i,
                p0: w.world_position_index(i),
                v0: dv(b.velocity),
                angle0: b.angle as f64,
                omega: b.angular_velocity as f64,
                rate,
            }
        };
        if movers.len() > 1 {
            // none touches another: apart at the start, with the same start velocity and
            // the same drag for their mass (they move as one)
            let v = w.bodies[movers[0]].velocity;
            let same = movers.iter().all(|&i| w.bodies[i].velocity == v);
            let per_mass = |i: usize| {
                let b = &w.bodies[i];
                let k = match (w.drag, &b.shape) {
                    (None, _) => 0.0,
                    (Some(d), Shape::Circle { radius }) => {
                        d.linear as f64
                            + d.quadratic as f64
                            + d.fluid_density as f64 * d.drag_coefficient as f64 * *radius as f64
                    }
                    (Some(_), _) => f64::NAN,
                };
                k * b.inv_mass as f64
            };
            let r0 = per_mass(movers[0]);
            let alike = movers
                .iter()
                .all(|&i| (per_mass(i) - r0).abs() <= 1e-9 * r0.abs());
            let apart = movers.iter().enumerate().all(|(n, &i)| {
                movers[n + 1..].iter().all(|&j| {
                    let (a, b) = (&w.bodies[i], &w.bodies[j]);
                    a.position.distance(b.position) > a.shape.radius() + b.shape.radius()
                })
            });
            if !(same && alike && apart) {
                return Err("bodies in flight that may meet".into());
            }
        }
        match w.drag {
            None => Ok(Exact::Flight {
                g,
                bodies: movers.iter().map(|&i| fly(i, 0.0)).collect(),
            }),
            Some(d)
                if d.quadratic == 0.0 && (d.fluid_density == 0.0 || d.drag_coefficient == 0.0) =>
            {
                Ok(Exact::Flight {
                    g,
                    bodies: movers
                        .iter()
                        .map(|&i| fly(i, d.linear as f64 * w.bodies[i].inv_mass as f64))
                        .collect(),
                })
            }
            Some(d) if d.linear == 0.0 && g.length() > 0.0 => {
                let down = g.normalize();
                let mut bodies = Vec::new();
                for &i in movers {
                    let b = &w.bodies[i];
                    let Shape::Circle { radius } = b.shape else {
                        return Err("quadratic drag on a body that is not a circle".into());
                    };
                    let v = dv(b.velocity);
                    if (v - down * v.dot(down)).length() > 0.0 || v.dot(down) < 0.0 {
                        return Err("quadratic drag on a body not moving along gravity".into());
                    }
                    let k = d.quadratic as f64
                        + 0.5
                            * d.fluid_density as f64
                            * d.drag_coefficient as f64
                            * 2.0
                            * radius as f64;
                    bodies.push(fly(i, k * b.inv_mass as f64));
                }
                Ok(Exact::QuadraticFall { g, bodies })
            }
            Some(_) => Err("linear and quadratic drag together".into()),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn spring(
        w: &World,
        body: usize,
        anchor: DVec2,
        rest: f64,
        compliance: f64,
        g: DVec2,
        horizon: f64,
    ) -> Result<Exact, String> {
        let b = &w.bodies[body];
        let d = w.world_position_index(body) - anchor;
        if d.length() < 1e-6 {
            return Err("the spring starts folded".into());
        }
        let dir = d.normalize();
        let v = dv(b.velocity);
        let off = |x: DVec2| (x - dir * x.dot(dir)).length();
        if off(v) > 1e-9 * (1.0 + v.length()) || off(g) > 1e-9 * (1.0 + g.length()) {
            return Err("the spring's body does not move along its line".into());
        }
        if b.angular_velocity != 0.0 {
            return Err("the spring's body turns".into());
        }
        let m = b.mass as f64;
        let omega = (1.0 / (compliance * m)).sqrt();
        let rest_eq = rest + g.dot(dir) / (omega * omega);
        let (x0, v0) = (d.length(), v.dot(dir));
        let amp = ((x0 - rest_eq).powi(2) + (v0 / omega).powi(2)).sqrt();
        if rest_eq - amp <= 0.0 {
            return Err("the spring would fold through its anchor".into());
        }
        let _ = horizon;
        Ok(Exact::Spring {
            body,
            anchor,
            dir,
            rest_eq,
            x0,
            v0,
            omega,
            angle: b.angle as f64,
        })
    }

    /// The face of the static polygon `ground` the circle of `radius` at `c` rests on:
    /// (its outward normal, its two ends), when the circle touches it within 0.1 mm.
    fn face_under(
        w: &World,
        ground: usize,
        c: DVec2,
        radius: f64,
    ) -> Option<(DVec2, DVec2, DVec2)> {
        let gb = &w.bodies[ground];
        let Shape::Polygon(poly) = &gb.shape else {
            return None;
        };
        let xf = gb.transform();
        let origin = w.world_position_index(ground) - dv(gb.position);
        (0..poly.count).find_map(|k| {
            let a = dv(xf.apply(poly.vertices[k])) + origin;
            let b = dv(xf.apply(poly.vertices[(k + 1) % poly.count])) + origin;
            let n = dv(gb.rot.rotate(poly.normals[k]));
            let along = (b - a).normalize();
            let t = (c - a).dot(along);
            let touching = ((c - a).dot(n) - radius - poly.radius as f64).abs() < 1e-4
                && t > 0.0
                && t < (b - a).length();
            touching.then_some((n, a, b))
        })
    }

    fn disk(
        w: &World,
        body: usize,
        ground: usize,
        r: f64,
        g: DVec2,
        horizon: f64,
    ) -> Result<Exact, String> {
        let b = &w.bodies[body];
        if !at_rest(b) {
            return Err("the disk does not start at rest".into());
        }
        let c = w.world_position_index(body);
        let Some((n, fa, fb)) = Self::face_under(w, ground, c, r) else {
            return Err("the disk does not rest on a face of the other body".into());
        };
        let gn = -g.dot(n);
        if !(gn > 0.0) {
            return Err("the face is not under the disk".into());
        }
        let along = g - n * g.dot(n);
        if along.length() < 1e-9 {
            return Err("the face is flat: the disk stays".into());
        }
        let down = along.normalize();
        let gs = g.dot(down);
        let mu = (b.friction as f64 * w.bodies[ground].friction as f64).sqrt();
        let (m, i) = (b.mass as f64, b.inertia as f64);
        let j = i / (m * r * r);
        // the sense in which rolling down turns the disk
        let sense = down.dot(perp(n)).signum();
        let rolling = mu * gn >= gs * j / (1.0 + j);
        let (accel, spin) = if rolling {
            let a = gs / (1.0 + j);
            (a, sense * a / r)
        } else {
            (gs - mu * gn, sense * mu * m * gn * r / i)
        };
        // on the face until the contact point reaches its lower end (less a radius)
        let end = if (fa - fb).dot(down) > 0.0 { fa } else { fb };
        let room = (end - (c - n * r)).dot(down) - r;
        let until = (2.0 * room.max(0.0) / accel).sqrt();
        if until < horizon {
            return Err(format!(
                "the disk leaves its ramp after {until:.2} s, within the horizon of {horizon:.2} s"
            ));
        }
        Ok(Exact::Disk {
            body,
            p0: c,
            down,
            accel,
            spin,
            rolling,
            angle: b.angle as f64,
            until,
        })
    }

    fn slide(w: &World, body: usize, ground: usize, g: DVec2) -> Result<Exact, String> {
        let b = &w.bodies[body];
        let Shape::Polygon(poly) = &b.shape else {
            return Err("not a polygon".into());
        };
        if g.length() == 0.0 || b.angular_velocity != 0.0 {
            return Err("no gravity, or the box turns".into());
        }
        let up = -g.normalize();
        let c = w.world_position_index(body);
        // the box's lowest point touches a face of the ground whose normal is up
        let xf = b.transform();
        let origin = c - dv(b.position);
        let low = (0..poly.count)
            .map(|k| dv(xf.apply(poly.vertices[k])) + origin)
            .map(|p| p.dot(up))
            .fold(f64::INFINITY, f64::min);
        let half = c.dot(up) - low;
        let Some((n, fa, fb)) = Self::face_under(w, ground, c, half) else {
            return Err("the box does not rest on a face of the ground".into());
        };
        if (n - up).length() > 1e-6 {
            return Err("the ground is not flat".into());
        }
        let width = (0..poly.count)
            .map(|k| dv(xf.apply(poly.vertices[k])).dot(perp(up)))
            .fold(f64::NEG_INFINITY, f64::max)
            - (0..poly.count)
                .map(|k| dv(xf.apply(poly.vertices[k])).dot(perp(up)))
                .fold(f64::INFINITY, f64::min);
        if width < 2.0 * half {
            return Err("the box is taller than wide: friction may tip it".into());
        }
        let v = dv(b.velocity);
        if v.dot(up).abs() > 1e-12 || v.length() == 0.0 {
            return Err("the box does not slide along the ground".into());
        }
        let dir = v.normalize();
        let mu = (b.friction as f64 * w.bodies[ground].friction as f64).sqrt();
        let decel = mu * g.length();
        if !(decel > 0.0) {
            return Err("no friction".into());
        }
        let stop = v.length() * v.length() / (2.0 * decel);
        let room = [fa, fb]
            .iter()
            .map(|e| (*e - c).dot(dir))
            .fold(f64::NEG_INFINITY, f64::max)
            - width / 2.0;
        if stop > room {
            return Err("the box slides off the ground".into());
        }
        Ok(Exact::Slide {
            body,
            p0: c,
            dir,
            v0: v.length(),
            decel,
            angle: b.angle as f64,
        })
    }

    /// The bodies it gives the motion of, in order.
    pub fn bodies(&self) -> Vec<usize> {
        match self {
            Exact::Flight { bodies, .. } | Exact::QuadraticFall { bodies, .. } => {
                bodies.iter().map(|b| b.body).collect()
            }
            Exact::Pendulum { body, .. }
            | Exact::Spring { body, .. }
            | Exact::Disk { body, .. }
            | Exact::Slide { body, .. } => vec![*body],
        }
    }

    /// The pose of its `k`-th body ([`Exact::bodies`]) at time `t` (s from the start).
    pub fn pose(&self, k: usize, t: f64) -> Pose {
        match self {
            Exact::Flight { g, bodies } => {
                let b = &bodies[k];
                let p = if b.rate == 0.0 {
                    b.p0 + b.v0 * t + 0.5 * *g * t * t
                } else {
                    let inf = *g / b.rate;
                    // (1 - e^(-rate t)) / rate without cancellation
                    let f = -(-b.rate * t).exp_m1() / b.rate;
                    b.p0 + inf * t + (b.v0 - inf) * f
                };
                Pose {
                    p,
                    angle: b.angle0 + b.omega * t,
                }
            }
            Exact::QuadraticFall { g, bodies } => {
                let b = &bodies[k];
                let gl = g.length();
                let down = *g / gl;
                let u = (gl / b.rate).sqrt();
                let c = (b.v0.dot(down) / u).clamp(0.0, 1.0 - 1e-15).atanh();
                let s = u * u / gl * (ln_cosh(gl * t / u + c) - ln_cosh(c));
                Pose {
                    p: b.p0 + down * s,
                    angle: b.angle0,
                }
            }
            Exact::Pendulum {
                pivot,
                length,
                theta0,
                g,
                angle,
                ..
            } => {
                let gl = g.length();
                let down = *g / gl;
                let k = (0.5 * theta0).sin();
                let m = k * k;
                let w0 = (gl / length).sqrt();
                let theta = 2.0 * (k * jacobi_sn(elliptic_k(m) - w0 * t, m)).asin();
                Pose {
                    p: *pivot + *length * (down * theta.cos() + perp(down) * theta.sin()),
                    angle: *angle,
                }
            }
            Exact::Spring {
                anchor,
                dir,
                rest_eq,
                x0,
                v0,
                omega,
                angle,
                ..
            } => {
                let x =
                    rest_eq + (x0 - rest_eq) * (omega * t).cos() + v0 / omega * (omega * t).sin();
                Pose {
                    p: *anchor + *dir * x,
                    angle: *angle,
                }
            }
            Exact::Disk {
                p0,
                down,
                accel,
                spin,
                angle,
                ..
            } => Pose {
                p: *p0 + *down * (0.5 * accel * t * t),
                angle: angle + 0.5 * spin * t * t,
            },
            Exact::Slide {
                p0,
                dir,
                v0,
                decel,
                angle,
                ..
            } => {
                let t = t.min(v0 / decel);
                Pose {
                    p: *p0 + *dir * (v0 * t - 0.5 * decel * t * t),
                    angle: *angle,
                }
            }
        }
    }

    /// One line: what the closed form is.
    pub fn describe(&self) -> String {
        match self {
            Exact::Flight { bodies, .. } => {
                let rate = bodies.first().map_or(0.0, |b| b.rate);
                if rate == 0.0 {
                    format!(
                        "closed form: {} bodies in free flight (x0 + v0 t + g t^2 / 2)",
                        bodies.len()
                    )
                } else {
                    format!(
                        "closed form: {} bodies in flight under linear drag (c/m = {rate:.3} 1/s: v relaxes to g m/c as e^(-c t/m))",
                        bodies.len()
                    )
                }
            }
            Exact::QuadraticFall { bodies, g } => {
                let u = bodies.first().map_or(0.0, |b| (g.length() / b.rate).sqrt());
                format!(
                    "closed form: {} bodies falling from rest under quadratic drag (terminal speed {u:.3} m/s, s = u^2/g ln cosh(g t/u))",
                    bodies.len()
                )
            }
            Exact::Pendulum { length, theta0, .. } => format!(
                "closed form: a point mass on a rigid rod of {length:.3} m released from rest at {:.1} degrees (Jacobi's sn, period {:.4} s)",
                theta0.to_degrees(),
                self.period().unwrap_or(f64::NAN)
            ),
            Exact::Spring { omega, .. } => format!(
                "closed form: a mass on a spring along its line (omega = sqrt(k/m) = {omega:.4} rad/s)"
            ),
            Exact::Disk { accel, rolling, .. } => format!(
                "closed form: a disk from rest down a ramp, {} (a = {accel:.4} m/s^2)",
                if *rolling {
                    "rolling without slipping"
                } else {
                    "sliding"
                }
            ),
            Exact::Slide { v0, decel, .. } => format!(
                "closed form: a box sliding at {v0:.3} m/s, stopped by friction (mu g = {decel:.3} m/s^2) after {:.3} s",
                v0 / decel
            ),
        }
    }

    /// The pendulum's period (s).
    pub fn period(&self) -> Option<f64> {
        match self {
            Exact::Pendulum {
                length, theta0, g, ..
            } => {
                let k = (0.5 * theta0).sin();
                Some(4.0 * elliptic_k(k * k) / (g.length() / length).sqrt())
            }
            _ => None,
        }
    }
}

/// How a reference run is made: the scene's own dt divided by `divide`, the solver's
/// solves converged (`iterations` sweeps at most, stopping below `tolerance`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefSpec {
    pub kind: SolverKind,
    pub divide: u32,
    pub substeps: u32,
    pub iterations: u32,
    pub tolerance: f32,
}

impl RefSpec {
    /// Classic PGS at a 16th of the scene's step, warm started with split impulse, up
    /// to 500 sweeps a step until every |delta lambda| < 1e-7 N s: the rigid-contact
    /// MLCP and the joints solved to convergence at every step.
    pub const CONVERGED_PGS: RefSpec = RefSpec {
        kind: SolverKind::Pgs,
        divide: 16,
        substeps: 1,
        iterations: 500,
        tolerance: 1e-7,
    };

    /// The settings of the reference for a scene whose `[solver]` is `scene`, at
    /// `divide` (this spec's, or half of it for the check run).
    pub fn settings(&self, scene: &SolverOverrides, divide: u32) -> SolverSettings {
        let base = scene.resolve();
        scene
            .merged(SolverOverrides {
                kind: Some(self.kind),
                dt: Some(base.dt / divide as f32),
                substeps: Some(self.substeps),
                iterations: Some(self.iterations),
                tolerance: Some(self.tolerance),
                warm_start: Some(true),
                split_impulse: Some(true),
                sleep: Some(false),
                ..Default::default()
            })
            .resolve()
    }

    /// One line: what the reference is.
    pub fn describe(&self, dt: f32) -> String {
        format!(
            "reference run: {} at dt/{} ({:.3e} s), up to {} sweeps a step to |delta lambda| < {:e}, warm started, split impulse",
            self.kind.label(),
            self.divide,
            dt as f64 / self.divide as f64,
            self.iterations,
            self.tolerance
        )
    }
}

/// The reference a bench scene's runs are compared with when it has no closed form,
/// or why it has none: converged PGS at a 16th of the step for every scene, but for
/// the two where no reference makes sense.
pub fn reference_for(scene: &str) -> Result<RefSpec, String> {
    match scene {
        "overlap_recovery" => Err(
            "its boxes start inside one another: how they come apart is each solver's recovery model, not a motion with a truth to compare with"
                .into(),
        ),
        "large_pyramid" => Err(
            "a reference of its 5050 boxes at 16 times the steps with converged solves would take hours"
                .into(),
        ),
        _ => Ok(RefSpec::CONVERGED_PGS),
    }
}

/// Works out the truth of each scene (closed form or reference; see
/// [`Truth::for_scene`]) for runs of `steps(scene)` steps, and where there is one makes
/// the trajectory error the scene's plotted measure and one of its measures.
/// `progress(done, total, name)` after each scene.
pub fn attach(
    scenes: &mut [super::BenchScene],
    steps: impl Fn(&super::BenchScene) -> u64,
    mut progress: impl FnMut(usize, usize, &str),
) {
    let total = scenes.len();
    for (i, sc) in scenes.iter_mut().enumerate() {
        if crate::output::interrupted() {
            return;
        }
        let truth = Truth::for_scene(&sc.def, steps(sc), reference_for(&sc.name));
        if truth.measures() {
            sc.primary = super::Metric::Trajectory;
            if !sc.metrics.contains(&super::Metric::Trajectory) {
                sc.metrics.push(super::Metric::Trajectory);
            }
        }
        sc.truth = Some(std::sync::Arc::new(truth));
        progress(i + 1, total, &sc.name);
    }
}

/// A reference trajectory: each tracked body's pose at every step of the run compared
/// with it (the reference's every `divide`-th step).
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    pub spec: RefSpec,
    /// The bodies tracked (dynamic at the start).
    pub bodies: Vec<usize>,
    /// `poses[k][j]`: body `bodies[j]` after the run's step k (k = 0: the start).
    pub poses: Vec<Vec<Pose>>,
    /// Its own error, estimated as its distance from the same reference at twice its
    /// step: RMS and worst position (m).
    pub own_rms: f64,
    pub own_max: f64,
    /// The RMS distance of the bodies from where they started, over the horizon (m).
    pub motion: f64,
    /// The scene's dt.
    pub dt: f32,
}

impl Reference {
    /// A reference is trusted when its own error (RMS) is below 1 mm plus 0.2% of the
    /// bodies' RMS motion over the horizon: well under the errors of the settings it
    /// ranks (a setting 1% off is 5 times as far from it as it is from the truth).
    pub const TRUSTED: (f64, f64) = (1e-3, 0.002);

    /// Whether its own error is small enough to rank settings by.
    pub fn trusted(&self) -> bool {
        self.own_rms <= Self::TRUSTED.0 + Self::TRUSTED.1 * self.motion
    }

    /// Runs the reference of `def` for the `steps` steps of a run at the scene's dt,
    /// and its check at twice its step. `Err` when a reference blows up.
    pub fn run(def: &WorldDef, spec: RefSpec, steps: u64) -> Result<Reference, String> {
        let record = |divide: u32| -> Result<(Vec<usize>, Vec<Vec<Pose>>), String> {
            let settings = spec.settings(&def.solver, divide);
            let mut w = World::from_def(def, settings).map_err(|e| e.to_string())?;
            let bodies = dynamic(&w);
            let pose = |w: &World| -> Vec<Pose> {
                bodies
                    .iter()
                    .map(|&i| Pose {
                        p: w.world_position_index(i),
                        angle: w.bodies[i].angle as f64,
                    })
                    .collect()
            };
            let mut poses = Vec::with_capacity(steps as usize + 1);
            poses.push(pose(&w));
            for k in 0..steps {
                if crate::output::interrupted() {
                    return Err("interrupted".into());
                }
                for _ in 0..divide {
                    w.step().map_err(|e| {
                        format!("the reference blew up at its step {}: {e}", w.step_count())
                    })?;
                }
                let _ = k;
                poses.push(pose(&w));
            }
            Ok((bodies, poses))
        };
        let (bodies, poses) = record(spec.divide)?;
        let (_, check) = record((spec.divide / 2).max(1))?;
        let (mut sum, mut max, mut n) = (0.0f64, 0.0f64, 0usize);
        let mut motion = 0.0f64;
        for (a, b) in poses.iter().zip(&check) {
            for (j, (p, q)) in a.iter().zip(b).enumerate() {
                let d = (p.p - q.p).length();
                sum += d * d;
                max = max.max(d);
                n += 1;
                motion += (p.p - poses[0][j].p).length_squared();
            }
        }
        let n = n.max(1) as f64;
        let dt = def.solver.resolve().dt;
        Ok(Reference {
            spec,
            bodies,
            poses,
            own_rms: (sum / n).sqrt(),
            own_max: max,
            motion: (motion / n).sqrt(),
            dt,
        })
    }
}

/// What a scene's runs are compared with.
#[derive(Clone, Debug, PartialEq)]
pub enum Truth {
    Exact(Exact),
    Reference(Reference),
    /// No trajectory error for this scene, and why.
    Unmeasured(String),
}

impl Truth {
    /// One line for the report: which truth the scene's runs were compared with.
    pub fn describe(&self) -> String {
        match self {
            Truth::Exact(e) => e.describe(),
            Truth::Reference(r) => format!(
                "{}; its own error (its distance from the same at twice its step) RMS {:.2e} m, worst {:.2e} m, trusted as under 1 mm + 0.2% of the bodies' motion ({:.3} m RMS)",
                r.spec.describe(r.dt),
                r.own_rms,
                r.own_max,
                r.motion
            ),
            Truth::Unmeasured(why) => format!("not measured: {why}"),
        }
    }

    /// Whether runs can be measured against it.
    pub fn measures(&self) -> bool {
        !matches!(self, Truth::Unmeasured(_))
    }

    /// The truth for a scene run `steps` steps at its own dt: its closed form when it
    /// has one, else a reference run made with `spec` (`None`: the scene is not
    /// measured, `why`), which must be trusted ([`Reference::trusted`]).
    pub fn for_scene(def: &WorldDef, steps: u64, spec: Result<RefSpec, String>) -> Truth {
        let settings = def.solver.resolve();
        let horizon = steps as f64 * settings.dt as f64;
        match World::from_def(
            def,
            SolverSettings {
                sleep: false,
                ..settings
            },
        ) {
            Ok(w) => {
                if let Ok(e) = Exact::of(&w, horizon) {
                    return Truth::Exact(e);
                }
            }
            Err(e) => return Truth::Unmeasured(format!("the scene does not build: {e}")),
        }
        let spec = match spec {
            Ok(s) => s,
            Err(why) => return Truth::Unmeasured(why),
        };
        match Reference::run(def, spec, steps) {
            Ok(r) if r.trusted() => Truth::Reference(r),
            Ok(r) => Truth::Unmeasured(format!(
                "chaotic (or not converged) over the {horizon:.1} s horizon: the {} and the same at twice its step are {:.3} m apart RMS ({:.3} m worst), over 1 mm + 0.2% of the bodies' motion ({:.3} m RMS)",
                r.spec.describe(r.dt).trim_start_matches("reference run: "),
                r.own_rms,
                r.own_max,
                r.motion
            )),
            Err(e) => Truth::Unmeasured(e),
        }
    }
}

/// A run's error against the truth, over the horizon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajError {
    /// RMS and worst distance of a body's centre from its true place (m).
    pub pos_rms: f64,
    pub pos_max: f64,
    /// RMS and worst difference of a body's angle from its true angle (rad).
    pub angle_rms: f64,
    pub angle_max: f64,
}

/// Accumulates a run's [`TrajError`] step by step.
#[derive(Clone, Debug)]
pub struct Tracker<'a> {
    truth: &'a Truth,
    bodies: Vec<usize>,
    sum_p: f64,
    max_p: f64,
    sum_a: f64,
    max_a: f64,
    n: usize,
    /// Where the run's time starts (the exact forms are in time since the start).
    t0: f64,
}

impl<'a> Tracker<'a> {
    /// A tracker of `world` (as built, before its first step) against `truth`; `None`
    /// when the truth measures nothing.
    pub fn new(truth: &'a Truth, world: &World) -> Option<Tracker<'a>> {
        let bodies = match truth {
            Truth::Exact(e) => e.bodies(),
            Truth::Reference(r) => r.bodies.clone(),
            Truth::Unmeasured(_) => return None,
        };
        Some(Tracker {
            truth,
            bodies,
            sum_p: 0.0,
            max_p: 0.0,
            sum_a: 0.0,
            max_a: 0.0,
            n: 0,
            t0: world.time(),
        })
    }

    /// Compares the world after its step `k` (counted from the run's start).
    pub fn observe(&mut self, k: usize, world: &World) {
        for (j, &i) in self.bodies.iter().enumerate() {
            let truth = match self.truth {
                Truth::Exact(e) => e.pose(j, world.time() - self.t0),
                Truth::Reference(r) => match r.poses.get(k) {
                    Some(p) => p[j],
                    None => continue,
                },
                Truth::Unmeasured(_) => return,
            };
            let d = (world.world_position_index(i) - truth.p).length();
            let a = (world.bodies[i].angle as f64 - truth.angle).abs();
            self.sum_p += d * d;
            self.max_p = self.max_p.max(d);
            self.sum_a += a * a;
            self.max_a = self.max_a.max(a);
            self.n += 1;
        }
    }

    /// The error so far (NaN figures before any step; infinite when a figure was).
    pub fn error(&self) -> TrajError {
        let n = self.n as f64;
        TrajError {
            pos_rms: (self.sum_p / n).sqrt(),
            pos_max: if self.n > 0 { self.max_p } else { f64::NAN },
            angle_rms: (self.sum_a / n).sqrt(),
            angle_max: if self.n > 0 { self.max_a } else { f64::NAN },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_elliptic_functions_match_their_known_values() {
        // K(0) = pi/2, K(1/2) = 1.854074677301372 (A&S table 17.1)
        assert!((elliptic_k(0.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((elliptic_k(0.5) - 1.854_074_677_301_372).abs() < 1e-13);
        // sn(K) = 1, sn(0) = 0, sn is odd, and sn(u | 0) = sin u
        for m in [0.1, 0.5, 0.9] {
            assert!((jacobi_sn(elliptic_k(m), m) - 1.0).abs() < 1e-12, "m {m}");
            assert!(jacobi_sn(0.0, m).abs() < 1e-15);
            assert!((jacobi_sn(0.7, m) + jacobi_sn(-0.7, m)).abs() < 1e-14);
        }
        assert!((jacobi_sn(0.3, 0.0) - 0.3f64.sin()).abs() < 1e-15);
        // sn^2 + cn^2 = 1 and d(sn)/du = cn dn: checked against a difference quotient
        let (u, m) = (0.9, 0.6);
        let h = 1e-6;
        let dsn = (jacobi_sn(u + h, m) - jacobi_sn(u - h, m)) / (2.0 * h);
        let sn = jacobi_sn(u, m);
        let (cn, dn) = ((1.0 - sn * sn).sqrt(), (1.0 - m * sn * sn).sqrt());
        assert!((dsn - cn * dn).abs() < 1e-8, "{dsn} against {}", cn * dn);
    }

    /// The pendulum's closed form against an RK4 integration in f64 of
    /// theta'' = -(g / L) sin theta, at 90 degrees (far from the small-angle law).
    #[test]
    fn the_pendulum_closed_form_solves_its_equation() {
        let (g, l, theta0) = (10.0f64, 2.0f64, std::f64::consts::FRAC_PI_2);
        let e = Exact::Pendulum {
            body: 0,
            pivot: DVec2::ZERO,
            length: l,
            theta0,
            g: DVec2::new(0.0, -g),
            angle: 0.0,
        };
        let f = |s: [f64; 2]| [s[1], -g / l * s[0].sin()];
        let mut s = [theta0, 0.0];
        let h = 1e-4;
        for k in 1..=30_000 {
            let k1 = f(s);
            let k2 = f([s[0] + 0.5 * h * k1[0], s[1] + 0.5 * h * k1[1]]);
            let k3 = f([s[0] + 0.5 * h * k2[0], s[1] + 0.5 * h * k2[1]]);
            let k4 = f([s[0] + h * k3[0], s[1] + h * k3[1]]);
            for i in 0..2 {
                s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            if k % 1000 == 0 {
                let p = e.pose(0, k as f64 * h).p;
                let want = DVec2::new(l * s[0].sin(), -l * s[0].cos());
                assert!(
                    (p - want).length() < 1e-9,
                    "t {}: {p} against {want}",
                    k as f64 * h
                );
            }
        }
        // the period at 90 degrees is 1.18034 times the small-angle 2 pi sqrt(L/g)
        let small = 2.0 * std::f64::consts::PI * (l / g).sqrt();
        assert!((e.period().unwrap() / small - 1.180_340_599).abs() < 1e-8);
    }

    /// Bodies in flight have a closed form only while none can meet another.
    #[test]
    fn flight_needs_bodies_that_move_as_one() {
        let scene = |second: &str| {
            let text = format!(
                "name = \"flight\"\n[world]\ngravity = [0.0, -10.0]\n[world.drag]\nlinear = 0.5\n\
                 [[body]]\nname = \"a\"\nshape = {{ circle = 0.2 }}\nvelocity = [3.0, 4.0]\n\
                 [[body]]\nname = \"b\"\nposition = [2.0, 0.0]\nvelocity = [3.0, 4.0]\n{second}\n"
            );
            let def = crate::scene::load_str(&text, "flight").unwrap().world;
            let w = World::from_def(&def, def.solver.resolve()).unwrap();
            Exact::of(&w, 1.0)
        };
        assert!(matches!(
            scene("shape = { circle = 0.2 }"),
            Ok(Exact::Flight { .. })
        ));
        // another mass: the drag slows it otherwise, and they may meet
        assert!(scene("shape = { circle = 0.2 }\ndensity = 3.0").is_err());
        // touching at the start
        assert!(scene("shape = { circle = 1.9 }").is_err());
    }

    #[test]
    fn the_drag_closed_forms_solve_their_equations() {
        // linear: x' = v, v' = g - b v; quadratic: u' = g - b u^2, by RK4 in f64
        let g = DVec2::new(0.0, -10.0);
        let lin = Exact::Flight {
            g,
            bodies: vec![Flying {
                body: 0,
                p0: DVec2::ZERO,
                v0: DVec2::new(8.0, 6.0),
                angle0: 0.0,
                omega: 0.0,
                rate: 0.7,
            }],
        };
        let quad = Exact::QuadraticFall {
            g,
            bodies: vec![Flying {
                rate: 0.3,
                v0: DVec2::ZERO,
                ..match &lin {
                    Exact::Flight { bodies, .. } => bodies[0],
                    _ => unreachable!(),
                }
            }],
        };
        let h = 1e-4;
        let (mut x, mut v) = (DVec2::ZERO, DVec2::new(8.0, 6.0));
        let (mut y, mut u) = (0.0f64, 0.0f64);
        let dl = |v: DVec2| g - 0.7 * v;
        let dq = |u: f64| 10.0 - 0.3 * u * u;
        for k in 1..=20_000 {
            let (a1, b1) = (v, dl(v));
            let (a2, b2) = (v + 0.5 * h * b1, dl(v + 0.5 * h * b1));
            let (a3, b3) = (v + 0.5 * h * b2, dl(v + 0.5 * h * b2));
            let (a4, b4) = (v + h * b3, dl(v + h * b3));
            x += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
            v += h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4);
            let (c1, e1) = (u, dq(u));
            let (c2, e2) = (u + 0.5 * h * e1, dq(u + 0.5 * h * e1));
            let (c3, e3) = (u + 0.5 * h * e2, dq(u + 0.5 * h * e2));
            let (c4, e4) = (u + h * e3, dq(u + h * e3));
            y += h / 6.0 * (c1 + 2.0 * c2 + 2.0 * c3 + c4);
            u += h / 6.0 * (e1 + 2.0 * e2 + 2.0 * e3 + e4);
            if k % 2000 == 0 {
                let t = k as f64 * h;
                assert!((lin.pose(0, t).p - x).length() < 1e-9, "linear at {t}");
                assert!(
                    (quad.pose(0, t).p - DVec2::new(0.0, -y)).length() < 1e-9,
                    "quadratic at {t}"
                );
            }
        }
    }
}
