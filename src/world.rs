//! The world: owns the bodies and runs the step pipeline
//! forces -> integrate velocities -> broad phase -> narrow phase -> contact cache
//! -> solver -> integrate positions -> step stats.

use std::time::Instant;

use crate::body::{Body, BodyId};
use crate::collision::broad_phase::BroadPhase;
use crate::collision::sat;
use crate::defs::{
    BodyDef, BodyModel, BodyType, DragDef, ForceDef, JointDef, SolverKind, SolverSettings, WorldDef,
};
use crate::math::{Aabb, Rot, Vec2, cross};
use crate::shape::{Shape, ShapeError};
use crate::solver::contact_cache::{CacheCursor, Contact, match_points};
use crate::solver::pgs::PgsSolver;
use crate::solver::soft::SoftSolver;

mod soft_step;

/// Contact points are kept while the gap is below this many slops (speculative contacts).
const SPECULATIVE_SLOPS: f32 = 4.0;

/// Why a world could not be built from its description.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    #[error("body \"{name}\": {source}")]
    Shape { name: String, source: ShapeError },
    #[error("body \"{0}\": a particle must have a circle shape")]
    ParticleShape(String),
    #[error("body \"{name}\": {what} must be > 0, got {value}")]
    NotPositive {
        name: String,
        what: &'static str,
        value: f32,
    },
    #[error("body \"{name}\": {what} is not a finite number")]
    NotFinite { name: String, what: &'static str },
    #[error("duplicate body name \"{0}\"")]
    DuplicateName(String),
    #[error("{what} names body #{index}, but the world has {count} bodies")]
    NoSuchBody {
        what: &'static str,
        index: usize,
        count: usize,
    },
    #[error("joints are not supported by this build yet ({0} joint(s) in the scene)")]
    JointsUnsupported(usize),
    #[error("solver: {0}")]
    Settings(String),
}

/// Why a step failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    #[error(
        "body \"{name}\" (#{index}) has a non-finite state after step {step}: position {position:?}, velocity {velocity:?}"
    )]
    NonFinite {
        name: String,
        index: usize,
        step: u64,
        position: Vec2,
        velocity: Vec2,
    },
    #[error("the {0} solver is not available in this build")]
    Unsupported(&'static str),
}

/// What one step did and cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// PGS velocity sweeps run (summed over substeps).
    pub iterations: u32,
    /// Largest |delta lambda| of the last sweep (N s).
    pub residual: f32,
    /// Split-impulse sweeps run.
    pub position_iterations: u32,
    /// Contact points (of the last substep).
    pub contacts: usize,
    /// Deepest overlap seen by the narrow phase this step (m, >= 0).
    pub penetration: f32,
    /// Time per stage (ms): forces and velocity integration, broad phase, narrow phase,
    /// solver, position integration.
    pub ms_forces: f32,
    pub ms_broad: f32,
    pub ms_narrow: f32,
    pub ms_solve: f32,
    pub ms_integrate: f32,
}

/// A constant force at a body point.
#[derive(Clone, Copy, Debug)]
struct PointForce {
    body: usize,
    force: Vec2,
    /// point relative to the centre of mass, body frame
    local: Vec2,
}

/// A physics world.
#[derive(Debug)]
pub struct World {
    /// The bodies, in creation order.
    pub bodies: Vec<Body>,
    /// m/s^2; `None` skips the gravity pass.
    pub gravity: Option<Vec2>,
    /// `None` = vacuum.
    pub drag: Option<DragDef>,
    /// The solver and its settings.
    pub settings: SolverSettings,
    forces: Vec<PointForce>,
    broad: BroadPhase,
    aabbs: Vec<Aabb>,
    dynamic: Vec<bool>,
    contacts: Vec<Contact>,
    old_contacts: Vec<Contact>,
    pgs: PgsSolver,
    soft: SoftSolver,
    stats: StepStats,
    step_count: u64,
    time: f64,
}

impl World {
    /// An empty world with the given gravity and solver settings.
    pub fn new(gravity: Option<Vec2>, settings: SolverSettings) -> World {
        World {
            bodies: Vec::new(),
            gravity,
            drag: None,
            settings,
            forces: Vec::new(),
            broad: BroadPhase::default(),
            aabbs: Vec::new(),
            dynamic: Vec::new(),
            contacts: Vec::new(),
            old_contacts: Vec::new(),
            pgs: PgsSolver::default(),
            soft: SoftSolver::default(),
            stats: StepStats::default(),
            step_count: 0,
            time: 0.0,
        }
    }

    /// Builds the world a description asks for, with these solver settings.
    pub fn from_def(def: &WorldDef, settings: SolverSettings) -> Result<World, BuildError> {
        check_settings(&settings)?;
        let mut w = World::new(def.gravity, settings);
        w.drag = def.drag;
        for b in &def.bodies {
            w.add_body(b)?;
        }
        for f in &def.forces {
            w.add_force(f)?;
        }
        if !def.joints.is_empty() {
            w.add_joints(&def.joints)?;
        }
        Ok(w)
    }

    fn add_joints(&mut self, joints: &[JointDef]) -> Result<(), BuildError> {
        Err(BuildError::JointsUnsupported(joints.len()))
    }

    /// Adds a body; its mass and inertia come from the shape and density (or the given mass).
    pub fn add_body(&mut self, def: &BodyDef) -> Result<BodyId, BuildError> {
        let name = def.name.clone();
        if self.bodies.iter().any(|b| b.name == name) {
            return Err(BuildError::DuplicateName(name));
        }
        let finite = |what: &'static str, ok: bool| {
            if ok {
                Ok(())
            } else {
                Err(BuildError::NotFinite {
                    name: name.clone(),
                    what,
                })
            }
        };
        finite("position", def.position.is_finite())?;
        finite("angle", def.angle.is_finite())?;
        finite("velocity", def.velocity.is_finite())?;
        finite("angular_velocity", def.angular_velocity.is_finite())?;
        finite("friction", def.friction.is_finite())?;
        finite("restitution", def.restitution.is_finite())?;
        let (shape, centroid) =
            Shape::from_def(&def.shape).map_err(|source| BuildError::Shape {
                name: name.clone(),
                source,
            })?;
        let particle = def.model == BodyModel::Particle;
        if particle && !matches!(shape, Shape::Circle { .. }) {
            return Err(BuildError::ParticleShape(name));
        }
        let dynamic = def.body_type == BodyType::Dynamic;
        let (mut mass, mut inertia) = (0.0, 0.0);
        if dynamic {
            let md = match def.mass {
                Some(m) => {
                    if !(m > 0.0) || !m.is_finite() {
                        return Err(BuildError::NotPositive {
                            name,
                            what: "mass",
                            value: m,
                        });
                    }
                    // scale the unit-density inertia to the given mass
                    let unit = shape.mass_data(1.0);
                    crate::shape::MassData {
                        mass: m,
                        center: unit.center,
                        inertia: unit.inertia * m / unit.mass,
                    }
                }
                None => {
                    if !(def.density > 0.0) || !def.density.is_finite() {
                        return Err(BuildError::NotPositive {
                            name,
                            what: "density",
                            value: def.density,
                        });
                    }
                    shape.mass_data(def.density)
                }
            };
            mass = md.mass;
            inertia = if particle { 0.0 } else { md.inertia };
        }
        let angle = if particle { 0.0 } else { def.angle };
        let rot = Rot::from_angle(angle);
        let body = Body {
            name,
            body_type: def.body_type,
            model: def.model,
            shape,
            origin_offset: -centroid,
            position: def.position + rot.rotate(centroid),
            angle,
            rot,
            velocity: def.velocity,
            angular_velocity: if particle { 0.0 } else { def.angular_velocity },
            mass,
            inv_mass: if mass > 0.0 { 1.0 / mass } else { 0.0 },
            inertia,
            inv_inertia: if inertia > 0.0 { 1.0 / inertia } else { 0.0 },
            friction: def.friction,
            restitution: def.restitution,
            color: def.color,
            force: Vec2::ZERO,
            torque: 0.0,
        };
        self.bodies.push(body);
        Ok(self.bodies.len() - 1)
    }

    /// Adds a constant force at a body point (the point is in the body's shape frame).
    pub fn add_force(&mut self, f: &ForceDef) -> Result<(), BuildError> {
        let Some(b) = self.bodies.get(f.body) else {
            return Err(BuildError::NoSuchBody {
                what: "force",
                index: f.body,
                count: self.bodies.len(),
            });
        };
        if !f.force.is_finite() || !f.point.is_finite() {
            return Err(BuildError::NotFinite {
                name: b.name.clone(),
                what: "force",
            });
        }
        let local = f.point + b.origin_offset;
        self.forces.push(PointForce {
            body: f.body,
            force: f.force,
            local,
        });
        Ok(())
    }

    /// Applies a force (N) at a world point for the next step only (the mouse's force emitter).
    pub fn apply_force(&mut self, body: BodyId, force: Vec2, world_point: Vec2) {
        if let Some(b) = self.bodies.get_mut(body) {
            if b.is_dynamic() {
                b.force += force;
                b.torque += cross(world_point - b.position, force);
            }
        }
    }

    /// The index of the body with this name.
    pub fn body_index(&self, name: &str) -> Option<BodyId> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Statistics of the last step.
    pub fn stats(&self) -> &StepStats {
        &self.stats
    }

    /// Steps taken.
    pub fn step_count(&self) -> u64 {
        self.step_count
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// This step's contacts (pairs and manifolds), sorted by pair.
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Advances the world by one step of `settings.dt` (in `settings.substeps` substeps).
    pub fn step(&mut self) -> Result<(), StepError> {
        match self.settings.kind {
            SolverKind::Pgs => {}
            SolverKind::Xpbd => return Err(StepError::Unsupported("xpbd")),
        }
        let n = self.settings.substeps.max(1);
        let h = self.settings.dt / n as f32;
        let mut total = StepStats::default();
        for _ in 0..n {
            if self.settings.soft_step {
                // one collide, n solver substeps inside (world/soft_step.rs)
                self.step_soft();
                total = self.stats;
                break;
            }
            self.substep_pgs(h);
            let s = self.stats;
            total.iterations += s.iterations;
            total.position_iterations += s.position_iterations;
            total.residual = s.residual;
            total.contacts = s.contacts;
            total.penetration = total.penetration.max(s.penetration);
            total.ms_forces += s.ms_forces;
            total.ms_broad += s.ms_broad;
            total.ms_narrow += s.ms_narrow;
            total.ms_solve += s.ms_solve;
            total.ms_integrate += s.ms_integrate;
        }
        self.stats = total;
        for b in &mut self.bodies {
            b.force = Vec2::ZERO;
            b.torque = 0.0;
        }
        self.step_count += 1;
        self.time += self.settings.dt as f64;
        self.check_finite()
    }

    fn check_finite(&self) -> Result<(), StepError> {
        for (i, b) in self.bodies.iter().enumerate() {
            if !(b.position.is_finite()
                && b.velocity.is_finite()
                && b.angle.is_finite()
                && b.angular_velocity.is_finite())
            {
                return Err(StepError::NonFinite {
                    name: b.name.clone(),
                    index: i,
                    step: self.step_count,
                    position: b.position,
                    velocity: b.velocity,
                });
            }
        }
        Ok(())
    }

    /// Semi-implicit Euler, velocity half: v += h (g + F/m), w += h tau / I; drag taken
    /// implicitly so it can only slow a body down, whatever the step.
    fn integrate_velocities(&mut self, h: f32) {
        // constant point forces: dv = h F / m, dw = h (r x F) / I
        for f in &self.forces {
            let b = &mut self.bodies[f.body];
            if b.is_dynamic() {
                let r = b.rot.rotate(f.local);
                b.velocity += h * b.inv_mass * f.force;
                b.angular_velocity += h * b.inv_inertia * cross(r, f.force);
            }
        }
        let g = self.gravity;
        let drag = self.drag;
        for b in &mut self.bodies {
            if !b.is_dynamic() {
                continue;
            }
            let mut v = b.velocity + h * b.inv_mass * b.force;
            if let Some(g) = g {
                v += h * g;
            }
            if let Some(d) = drag {
                // F = -(k1 + k2 |v|) v with k2 = quadratic + 1/2 rho Cd width; backward Euler in the factor
                let speed = v.length();
                let mut k = d.linear + d.quadratic * speed;
                if d.fluid_density > 0.0 && d.drag_coefficient > 0.0 && speed > 0.0 {
                    let width = b.shape.extent_across(&b.transform(), v / speed);
                    k += 0.5 * d.fluid_density * d.drag_coefficient * width * speed;
                }
                v /= 1.0 + h * k * b.inv_mass;
            }
            b.velocity = v;
            b.angular_velocity += h * b.inv_inertia * b.torque;
        }
    }

    fn collide(&mut self, h: f32) -> (f32, f32) {
        let t0 = Instant::now();
        let margin = SPECULATIVE_SLOPS * self.settings.slop.max(0.001);
        self.aabbs.clear();
        self.dynamic.clear();
        for b in &self.bodies {
            let mut bb = b.shape.aabb(&b.transform());
            // grow moving boxes by their motion this step so fast bodies find their pairs
            if b.body_type != BodyType::Static {
                let d = b.velocity * h;
                bb = Aabb {
                    min: bb.min + d.min(Vec2::ZERO),
                    max: bb.max + d.max(Vec2::ZERO),
                };
            }
            self.aabbs.push(bb.fattened(0.5 * margin));
            self.dynamic.push(b.is_dynamic());
        }
        self.broad
            .find_pairs(&self.aabbs, &self.dynamic, |_, _| true);
        let t1 = Instant::now();

        std::mem::swap(&mut self.contacts, &mut self.old_contacts);
        self.contacts.clear();
        let mut cache = CacheCursor::new(&self.old_contacts);
        let mut deepest = 0.0f32;
        for &(a, b) in &self.broad.pairs {
            let (ba, bb) = (&self.bodies[a as usize], &self.bodies[b as usize]);
            let mut m = sat::collide(
                &ba.shape,
                &ba.transform(),
                &bb.shape,
                &bb.transform(),
                margin,
            );
            if m.count == 0 {
                continue;
            }
            if let Some(old) = cache.find(a, b) {
                match_points(old, &mut m);
            }
            for p in m.points() {
                deepest = deepest.max(-p.separation);
            }
            self.contacts.push(Contact {
                a,
                b,
                manifold: m,
                // mu = sqrt(mu_a mu_b), e = max(e_a, e_b)
                friction: (ba.friction * bb.friction).sqrt(),
                restitution: ba.restitution.max(bb.restitution),
            });
        }
        let t2 = Instant::now();
        self.stats.penetration = deepest;
        ((t1 - t0).as_secs_f32() * 1e3, (t2 - t1).as_secs_f32() * 1e3)
    }

    fn substep_pgs(&mut self, h: f32) {
        let (ms_broad, ms_narrow) = self.collide(h);
        let t1 = Instant::now();
        self.integrate_velocities(h);
        let t2 = Instant::now();
        let settings = self.settings;
        self.pgs.prepare(&self.bodies, &self.contacts, &settings, h);
        let s = self.pgs.solve(&settings);
        self.pgs.store_impulses(&mut self.contacts);
        let t3 = Instant::now();
        // positions: x += h (v + v_pseudo), theta += h (w + w_pseudo)
        for (i, b) in self.bodies.iter_mut().enumerate() {
            match b.body_type {
                BodyType::Static => continue,
                BodyType::Kinematic => {}
                BodyType::Dynamic => {
                    let sb = self.pgs.bodies[i];
                    b.velocity = sb.v;
                    b.angular_velocity = sb.w;
                }
            }
            let (pv, pw) = if b.is_dynamic() {
                self.pgs.pseudo[i]
            } else {
                (Vec2::ZERO, 0.0)
            };
            b.position += h * (b.velocity + pv);
            if b.model == BodyModel::Rigid {
                b.angle += h * (b.angular_velocity + pw);
                b.rot = Rot::from_angle(b.angle);
            }
        }
        let t4 = Instant::now();
        self.stats.iterations = s.iterations;
        self.stats.residual = s.residual;
        self.stats.position_iterations = s.position_iterations;
        self.stats.contacts = self.contacts.iter().map(|c| c.manifold.count).sum();
        self.stats.ms_broad = ms_broad;
        self.stats.ms_narrow = ms_narrow;
        self.stats.ms_forces = (t2 - t1).as_secs_f32() * 1e3;
        self.stats.ms_solve = (t3 - t2).as_secs_f32() * 1e3;
        self.stats.ms_integrate = (t4 - t3).as_secs_f32() * 1e3;
    }

    /// Kinetic plus gravitational potential energy of the dynamic bodies (J), with the
    /// potential zero at the origin: E = sum 1/2 m v^2 + 1/2 I w^2 - m g.x
    pub fn energy(&self) -> f64 {
        let g = self.gravity.unwrap_or(Vec2::ZERO);
        self.bodies
            .iter()
            .filter(|b| b.is_dynamic())
            .map(|b| b.kinetic_energy() as f64 - (b.mass * g.dot(b.position)) as f64)
            .sum()
    }

    /// A 64-bit FNV-1a digest of every body's position, angle and velocities, bit for bit.
    pub fn state_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |x: f32| {
            for byte in x.to_bits().to_le_bytes() {
                h ^= byte as u64;
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for b in &self.bodies {
            eat(b.position.x);
            eat(b.position.y);
            eat(b.angle);
            eat(b.velocity.x);
            eat(b.velocity.y);
            eat(b.angular_velocity);
        }
        h
    }
}

/// Refuses settings the solver cannot run with.
pub fn check_settings(s: &SolverSettings) -> Result<(), BuildError> {
    let bad = |m: String| Err(BuildError::Settings(m));
    if !(s.dt > 0.0) || !s.dt.is_finite() {
        return bad(format!("dt must be > 0, got {}", s.dt));
    }
    if s.iterations == 0 {
        return bad("iterations must be at least 1".into());
    }
    if s.substeps == 0 {
        return bad("substeps must be at least 1".into());
    }
    if !(s.tolerance >= 0.0) {
        return bad(format!("tolerance must be >= 0, got {}", s.tolerance));
    }
    if !(s.slop >= 0.0) || !s.slop.is_finite() {
        return bad(format!("slop must be >= 0, got {}", s.slop));
    }
    if !(0.0..=1.0).contains(&s.baumgarte) {
        return bad(format!("baumgarte must be in [0, 1], got {}", s.baumgarte));
    }
    if !(s.contact_hertz >= 0.0) || !(s.contact_damping_ratio >= 0.0) {
        return bad(format!(
            "contact_hertz and contact_damping_ratio must be >= 0, got {} and {}",
            s.contact_hertz, s.contact_damping_ratio
        ));
    }
    if !(s.max_push_speed > 0.0) {
        return bad(format!(
            "max_push_speed must be > 0, got {}",
            s.max_push_speed
        ));
    }
    if !(s.restitution_threshold >= 0.0) {
        return bad(format!(
            "restitution_threshold must be >= 0, got {}",
            s.restitution_threshold
        ));
    }
    Ok(())
}
