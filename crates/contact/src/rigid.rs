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
    /// A ball (3D) or a disk (2D) of radius `r`.
    pub fn ball(dim: usize, r: f64) -> Self {
        if dim == 2 {
            Geometry::D2(parry2d_f64::shape::SharedShape::ball(r))
        } else {
            Geometry::D3(
                parry3d_f64::shape::SharedShape::ball(r),
                parry3d_f64::math::Rotation::IDENTITY,
            )
        }
    }

    /// A box with these edge lengths (2 or 3 used), centred on the reference point.
    pub fn cuboid(dim: usize, size: [f64; 3]) -> Self {
        if dim == 2 {
            Geometry::D2(parry2d_f64::shape::SharedShape::cuboid(
                0.5 * size[0],
                0.5 * size[1],
            ))
        } else {
            Geometry::D3(
                parry3d_f64::shape::SharedShape::cuboid(
                    0.5 * size[0],
                    0.5 * size[1],
                    0.5 * size[2],
                ),
                parry3d_f64::math::Rotation::IDENTITY,
            )
        }
    }

    /// A 3D circular cylinder along coordinate `axis` (0, 1, 2), centred.
    pub fn cylinder(radius: f64, length: f64, axis: usize) -> Self {
        use parry3d_f64::math::Rotation;
        // parry's cylinder lies along y; turn it onto the axis asked for.
        let rot = match axis {
            0 => Rotation::from_rotation_z(-std::f64::consts::FRAC_PI_2),
            1 => Rotation::IDENTITY,
            _ => Rotation::from_rotation_x(std::f64::consts::FRAC_PI_2),
        };
        Geometry::D3(
            parry3d_f64::shape::SharedShape::cylinder(0.5 * length, radius),
            rot,
        )
    }

    /// A capsule: the segment of `length` along `axis`, centred, swept by a ball of `radius`.
    pub fn capsule(dim: usize, radius: f64, length: f64, axis: usize) -> Self {
        let mut e = [0.0; 3];
        e[axis] = 0.5 * length;
        if dim == 2 {
            use parry2d_f64::math::Vector as V2;
            Geometry::D2(parry2d_f64::shape::SharedShape::capsule(
                V2::new(-e[0], -e[1]),
                V2::new(e[0], e[1]),
                radius,
            ))
        } else {
            use parry3d_f64::math::Vector as V3;
            Geometry::D3(
                parry3d_f64::shape::SharedShape::capsule(
                    V3::new(-e[0], -e[1], -e[2]),
                    V3::new(e[0], e[1], e[2]),
                    radius,
                ),
                parry3d_f64::math::Rotation::IDENTITY,
            )
        }
    }

    /// The solid half-space behind the plane through the reference point with outward unit
    /// normal `n`.
    pub fn halfspace(dim: usize, n: [f64; 3]) -> Self {
        if dim == 2 {
            Geometry::D2(parry2d_f64::shape::SharedShape::halfspace(
                parry2d_f64::math::Vector::new(n[0], n[1]),
            ))
        } else {
            Geometry::D3(
                parry3d_f64::shape::SharedShape::halfspace(parry3d_f64::math::Vector::new(
                    n[0], n[1], n[2],
                )),
                parry3d_f64::math::Rotation::IDENTITY,
            )
        }
    }

    /// A convex polygon (2D) from its vertices; `Err` with the reason when they span no area or
    /// are not convex.
    pub fn convex_polygon(points: &[[f64; 2]]) -> Result<Self, String> {
        use parry2d_f64::math::Vector as V2;
        let v: Vec<V2> = points.iter().map(|q| V2::new(q[0], q[1])).collect();
        let hull = parry2d_f64::shape::SharedShape::convex_hull(&v)
            .ok_or_else(|| "the points span no area".to_string())?;
        let n = hull.as_convex_polygon().map_or(0, |c| c.points().len());
        if n != v.len() {
            return Err(format!(
                "the polygon is not convex ({n} of its {} points are on its hull): split it into \
                 convex bodies",
                v.len()
            ));
        }
        Ok(Geometry::D2(hull))
    }

    /// A closed triangle mesh (3D).
    pub fn mesh(m: &crate::MeshShape) -> Self {
        Geometry::D3(
            parry3d_f64::shape::SharedShape::new(m.trimesh().clone()),
            parry3d_f64::math::Rotation::IDENTITY,
        )
    }

    /// A surface to draw the shape placed at `x` with: triangles in 3D, a closed polyline in 2D
    /// (points, triangles, line segments). Half-spaces are drawn as a patch of half-size `size`
    /// around their plane point; round shapes are faceted.
    #[allow(clippy::type_complexity)]
    pub fn surface(&self, x: [f64; 3], size: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>, Vec<[u32; 2]>) {
        match self {
            Geometry::D3(s, rot) => {
                use parry3d_f64::math::Vector as V3;
                let (pts, tris): (Vec<V3>, Vec<[u32; 3]>) = if let Some(b) = s.as_ball() {
                    b.to_trimesh(24, 12)
                } else if let Some(c) = s.as_cuboid() {
                    c.to_trimesh()
                } else if let Some(c) = s.as_cylinder() {
                    c.to_trimesh(32)
                } else if let Some(c) = s.as_capsule() {
                    c.to_trimesh(24, 12)
                } else if let Some(m) = s.as_trimesh() {
                    (m.vertices().to_vec(), m.indices().to_vec())
                } else if let Some(h) = s.as_halfspace() {
                    let n = h.normal;
                    let t1 = if n.x.abs() < 0.9 {
                        n.cross(V3::new(1.0, 0.0, 0.0)).normalize()
                    } else {
                        n.cross(V3::new(0.0, 1.0, 0.0)).normalize()
                    };
                    let t2 = n.cross(t1);
                    let c = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
                    (
                        c.iter().map(|&(a, b)| (t1 * a + t2 * b) * size).collect(),
                        vec![[0, 1, 2], [0, 2, 3]],
                    )
                } else {
                    (Vec::new(), Vec::new())
                };
                let pose = parry3d_f64::math::Pose::from_parts(V3::new(x[0], x[1], x[2]), *rot);
                let pts = pts
                    .iter()
                    .map(|&p| {
                        let q = pose.transform_point(p);
                        [q.x, q.y, q.z]
                    })
                    .collect();
                (pts, tris, Vec::new())
            }
            Geometry::D2(s) => {
                use parry2d_f64::math::Vector as V2;
                let pts: Vec<V2> = if let Some(b) = s.as_ball() {
                    b.to_polyline(48)
                } else if let Some(c) = s.as_cuboid() {
                    c.to_polyline()
                } else if let Some(c) = s.as_capsule() {
                    c.to_polyline(24)
                } else if let Some(p) = s.as_convex_polygon() {
                    p.points().to_vec()
                } else if let Some(h) = s.as_halfspace() {
                    let t = V2::new(-h.normal.y, h.normal.x);
                    vec![t * (-size), t * size]
                } else {
                    Vec::new()
                };
                let n = pts.len() as u32;
                let closed = s.as_halfspace().is_none();
                let lines = (0..n)
                    .filter(|&k| closed || k + 1 < n)
                    .map(|k| [k, (k + 1) % n])
                    .collect();
                let pts = pts.iter().map(|p| [p.x + x[0], p.y + x[1], 0.0]).collect();
                (pts, Vec::new(), lines)
            }
        }
    }

    /// True for shapes without a finite volume (half-spaces).
    pub fn is_unbounded(&self) -> bool {
        match self {
            Geometry::D2(s) => s.as_halfspace().is_some(),
            Geometry::D3(s, _) => s.as_halfspace().is_some(),
        }
    }

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
