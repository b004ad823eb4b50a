//! Rigid bodies: a parry shape (2D or 3D) that translates, either with a prescribed velocity
//! (kinematic: supports, platens, indenters) or moved by the contact reactions (dynamic:
//! projectiles, impactors). Bodies do not rotate: the impactors of our benchmarks hit
//! head-on, and a translating body keeps the contact law conservative and simple; rotation
//! would need the inertia tensor and a torque balance (left for later).
//!
//! parry 0.26+ works in glam types; this module converts `[f64; 3]` at its edges.

use hooke_core::loading::TimeFunction;

/// The shape of a rigid body in its own frame (its reference point at the origin).
#[derive(Clone)]
pub enum Geometry {
    /// A 2D shape in the x-y plane (for plate lattices).
    D2(parry2d_f64::shape::SharedShape),
    /// A 3D shape with a fixed orientation.
    D3(parry3d_f64::shape::SharedShape, parry3d_f64::math::Rotation),
}

impl std::fmt::Debug for Geometry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Geometry::D2(s) => write!(f, "D2({:?})", s.shape_type()),
            Geometry::D3(s, _) => write!(f, "D3({:?})", s.shape_type()),
        }
    }
}

impl Geometry {
    /// Signed distance of `p` from the surface of the shape placed at `x` (negative inside) and
    /// the outward normal at the nearest surface point. `None` when `p` lies exactly on the
    /// surface (no normal; no force either).
    pub fn signed_distance(&self, x: [f64; 3], p: [f64; 3]) -> Option<(f64, [f64; 3])> {
        let (d, inside) = match self {
            Geometry::D2(s) => {
                let pose = parry2d_f64::math::Pose::from_translation(
                    parry2d_f64::math::Vector::new(x[0], x[1]),
                );
                let q = parry2d_f64::math::Vector::new(p[0], p[1]);
                let pr = s.project_point(&pose, q, false);
                ([q.x - pr.point.x, q.y - pr.point.y, 0.0], pr.is_inside)
            }
            Geometry::D3(s, rot) => {
                let pose = parry3d_f64::math::Pose::from_parts(
                    parry3d_f64::math::Vector::new(x[0], x[1], x[2]),
                    *rot,
                );
                let q = parry3d_f64::math::Vector::new(p[0], p[1], p[2]);
                let pr = s.project_point(&pose, q, false);
                (
                    [q.x - pr.point.x, q.y - pr.point.y, q.z - pr.point.z],
                    pr.is_inside,
                )
            }
        };
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if len == 0.0 {
            return None;
        }
        let s = if inside { -1.0 } else { 1.0 };
        Some((s * len, [s * d[0] / len, s * d[1] / len, s * d[2] / len]))
    }

    /// Axis-aligned bounds of the shape placed at `x` (z spans everything in 2D).
    pub fn bounds(&self, x: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        match self {
            Geometry::D2(s) => {
                let pose = parry2d_f64::math::Pose::from_translation(
                    parry2d_f64::math::Vector::new(x[0], x[1]),
                );
                let b = s.compute_aabb(&pose);
                (
                    [b.mins.x, b.mins.y, f64::NEG_INFINITY],
                    [b.maxs.x, b.maxs.y, f64::INFINITY],
                )
            }
            Geometry::D3(s, rot) => {
                let pose = parry3d_f64::math::Pose::from_parts(
                    parry3d_f64::math::Vector::new(x[0], x[1], x[2]),
                    *rot,
                );
                let b = s.compute_aabb(&pose);
                (
                    [b.mins.x, b.mins.y, b.mins.z],
                    [b.maxs.x, b.maxs.y, b.maxs.z],
                )
            }
        }
    }

    /// Mass of the shape at `density` (kg/m^3; in 2D per unit thickness, times `thickness`).
    /// Infinite for unbounded shapes (half-spaces).
    pub fn mass(&self, density: f64, thickness: f64) -> f64 {
        match self {
            Geometry::D2(s) => s.mass_properties(density).mass() * thickness,
            Geometry::D3(s, _) => s.mass_properties(density).mass(),
        }
    }
}

/// How a body moves.
#[derive(Clone, Debug)]
pub enum Motion {
    /// Velocity prescribed per axis as a function of time (m/s).
    Kinematic([TimeFunction; 3]),
    /// Moved by the contact reactions: mass (kg) and the half-step velocity (m/s).
    Dynamic { mass: f64 },
}

/// A rigid body and its history.
#[derive(Clone, Debug)]
pub struct RigidBody {
    pub name: String,
    pub geometry: Geometry,
    pub motion: Motion,
    /// Position of the reference point at the current time (m).
    pub position: [f64; 3],
    /// Velocity at the half step before the current time (leapfrog), m/s.
    pub velocity: [f64; 3],
    /// Coulomb friction coefficient with the lattice.
    pub friction: f64,
    /// Force the lattice exerts on the body at the last step (N).
    pub reaction: [f64; 3],
}

impl RigidBody {
    /// Kinetic energy from the half-step velocity (J); zero for kinematic bodies.
    pub fn kinetic(&self) -> f64 {
        match self.motion {
            Motion::Dynamic { mass } => {
                0.5 * mass * self.velocity.iter().map(|v| v * v).sum::<f64>()
            }
            Motion::Kinematic(_) => 0.0,
        }
    }

    /// Momentum from the half-step velocity (kg m/s); zero for kinematic bodies.
    pub fn momentum(&self) -> [f64; 3] {
        match self.motion {
            Motion::Dynamic { mass } => self.velocity.map(|v| mass * v),
            Motion::Kinematic(_) => [0.0; 3],
        }
    }

    /// Advance by one step under the reaction `r` (N): `V(t + dt/2) = V(t - dt/2) + dt r / M`,
    /// `X(t + dt) = X(t) + dt V(t + dt/2)`; kinematic bodies take their prescribed velocity at
    /// `t + dt/2`.
    pub fn advance(&mut self, r: [f64; 3], t: f64, dt: f64, dim: usize) {
        self.reaction = r;
        match &self.motion {
            Motion::Dynamic { mass } => {
                for c in 0..dim {
                    self.velocity[c] += dt * r[c] / mass;
                }
            }
            Motion::Kinematic(f) => {
                for c in 0..3 {
                    self.velocity[c] = f[c].value(t + 0.5 * dt);
                }
            }
        }
        for c in 0..dim {
            self.position[c] += dt * self.velocity[c];
        }
    }
}
