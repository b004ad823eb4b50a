//! Rigid bodies: a parry shape (2D or 3D) that moves either as prescribed (kinematic:
//! supports, platens, indenters, with a velocity and an optional constant spin about the
//! reference point) or under the contact reactions (dynamic: projectiles, impactors), which
//! translate and rotate it.
//!
//! # Rotation of a dynamic body
//!
//! The state is the centre of mass `X_c`, its velocity `V`, the orientation `R` (a unit
//! quaternion, body frame to world) and the angular momentum `L` about the centre of mass, in
//! the world frame. Leapfrog, as for the lattice:
//!
//! ```text
//! V(t + dt/2) = V(t - dt/2) + dt F(t) / M          X_c(t + dt) = X_c(t) + dt V(t + dt/2)
//! L(t + dt/2) = L(t - dt/2) + dt tau(t)            R(t + dt) = exp(dt w) R(t)
//! w = R_m I_0^-1 R_m^T L(t + dt/2),  R_m = exp(dt w / 2) R(t)   (implicit midpoint, iterated)
//! ```
//!
//! with `I_0` the inertia tensor about the centre of mass in the body frame (parry's mass
//! properties, scaled to the body's mass) and `tau = sum (x_i - X_c) x F_i` over the contact
//! forces on the body, applied where the node is: the force on the node and its reaction act on
//! one line, so the pair exerts no net torque and the total angular momentum of lattice and
//! body is conserved. `L` is the state, so a free body keeps its angular momentum exactly
//! (to round-off: it is not touched). In 2D (plates) a body turns about z only.
//!
//! A body that has never turned (orientation exactly the identity) is placed and drawn by the
//! same arithmetic as before rotation existed, so runs without torque are unchanged bit for
//! bit.
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

/// The rotational inertia of a dynamic body: about its centre of mass, in the body frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inertia {
    /// Centre of mass in the body frame, from the reference point (m).
    pub center: [f64; 3],
    /// Inertia tensor about the centre of mass, body frame (kg m^2).
    pub tensor: [[f64; 3]; 3],
    /// Its inverse (1/(kg m^2)); in 2D only the z-z entry is non-zero (turning about z).
    pub inverse: [[f64; 3]; 3],
}

impl Inertia {
    /// The inertia of `geometry` carrying `mass` (kg), uniform density. `None` for unbounded
    /// shapes or shapes without volume.
    pub fn of(geometry: &Geometry, mass: f64) -> Option<Self> {
        if geometry.is_unbounded() || !(mass > 0.0) {
            return None;
        }
        match geometry {
            Geometry::D2(s) => {
                let mp = s.mass_properties(1.0);
                let scale = mass / mp.mass();
                let iz = mp.principal_inertia() * scale;
                if !(iz > 0.0 && iz.is_finite()) {
                    return None;
                }
                let c = mp.local_com;
                let mut tensor = [[0.0; 3]; 3];
                tensor[2][2] = iz;
                let mut inverse = [[0.0; 3]; 3];
                inverse[2][2] = 1.0 / iz;
                Some(Inertia {
                    center: [c.x, c.y, 0.0],
                    tensor,
                    inverse,
                })
            }
            Geometry::D3(s, rot) => {
                let mp = s.mass_properties(1.0);
                let scale = mass / mp.mass();
                // The shape's own frame, turned by the geometry's fixed rotation into the body's.
                let r = parry3d_f64::math::Matrix::from_quat(*rot);
                let i = r * mp.reconstruct_inertia_matrix() * r.transpose() * scale;
                let c = *rot * mp.local_com;
                let inv = i.inverse();
                let m = |a: parry3d_f64::math::Matrix| -> [[f64; 3]; 3] {
                    [0, 1, 2].map(|row| [0, 1, 2].map(|col| a.col(col)[row]))
                };
                let tensor = m(i);
                let inverse = m(inv);
                if !(i.determinant() > 0.0 && inverse.iter().flatten().all(|x| x.is_finite())) {
                    return None;
                }
                Some(Inertia {
                    center: [c.x, c.y, c.z],
                    tensor,
                    inverse,
                })
            }
        }
    }
}

/// A rigid body and its history.
#[derive(Clone, Debug)]
pub struct RigidBody {
    pub name: String,
    pub geometry: Geometry,
    pub motion: Motion,
    /// Position of the reference point at the current time (m).
    pub position: [f64; 3],
    /// Velocity at the half step before the current time (leapfrog), m/s: of the reference
    /// point for kinematic bodies, of the centre of mass for dynamic ones (the same point for
    /// the centred primitive shapes).
    pub velocity: [f64; 3],
    /// Coulomb friction coefficient with the lattice.
    pub friction: f64,
    /// Force the lattice exerts on the body at the last step (N).
    pub reaction: [f64; 3],
    /// Orientation at the current time: the unit quaternion `(w, x, y, z)` that turns the body
    /// frame into the world frame (the identity at the start).
    pub orientation: [f64; 4],
    /// Angular velocity at the half step (rad/s, world frame): prescribed and constant for a
    /// kinematic body (about its reference point), from the angular momentum for a dynamic one.
    pub spin: [f64; 3],
    /// Angular momentum about the centre of mass at the half step (kg m^2/s, world frame);
    /// dynamic bodies that rotate.
    pub angular_momentum: [f64; 3],
    /// Torque of the lattice on the body about its centre of mass at the last step (N m).
    pub torque: [f64; 3],
    /// The rotational inertia of a dynamic body that rotates; `None`: it only translates
    /// (kinematic bodies, and dynamic ones whose rotation is switched off).
    pub inertia: Option<Inertia>,
}

/// The identity rotation.
pub const IDENTITY: [f64; 4] = [1.0, 0.0, 0.0, 0.0];

impl RigidBody {
    /// A body at `position` with the half-step `velocity`, not turned, not turning. A dynamic
    /// body gets its inertia from its shape and mass (it rotates under the contact torques);
    /// [`RigidBody::without_rotation`] keeps it translating only.
    pub fn new(
        name: impl Into<String>,
        geometry: Geometry,
        motion: Motion,
        position: [f64; 3],
        velocity: [f64; 3],
        friction: f64,
    ) -> Self {
        let inertia = match &motion {
            Motion::Dynamic { mass } => Inertia::of(&geometry, *mass),
            Motion::Kinematic(_) => None,
        };
        RigidBody {
            name: name.into(),
            geometry,
            motion,
            position,
            velocity,
            friction,
            reaction: [0.0; 3],
            orientation: IDENTITY,
            spin: [0.0; 3],
            angular_momentum: [0.0; 3],
            torque: [0.0; 3],
            inertia,
        }
    }

    /// The same body translating only (no inertia, no spin).
    pub fn without_rotation(mut self) -> Self {
        self.inertia = None;
        self.spin = [0.0; 3];
        self.angular_momentum = [0.0; 3];
        self
    }

    /// Start turning at `w` (rad/s, world frame): the prescribed spin of a kinematic body, the
    /// initial one of a dynamic body (its angular momentum `I w`). In 2D only `w_z` is kept.
    pub fn with_spin(mut self, w: [f64; 3], dim: usize) -> Self {
        let w = if dim == 2 { [0.0, 0.0, w[2]] } else { w };
        self.spin = w;
        if let Some(inertia) = &self.inertia {
            let i = world(&inertia.tensor, self.orientation);
            self.angular_momentum = mat_vec(&i, w);
        }
        self
    }

    /// The spin settings of a case file or a builder: `rotates` (false keeps a dynamic body
    /// translating) and `angular_velocity` (`[wx, wy, wz]` in 3D, `[wz]` in 2D, rad/s). A
    /// mistake names its key (`"rotates"` or `"angular_velocity"`) and the fix.
    pub fn with_spin_settings(
        mut self,
        rotates: Option<bool>,
        angular_velocity: Option<&[f64]>,
        dim: usize,
    ) -> Result<Self, (&'static str, &'static str)> {
        if let Some(r) = rotates {
            if matches!(self.motion, Motion::Kinematic(_)) {
                return Err((
                    "rotates",
                    "a kinematic body turns only as prescribed: remove rotates and give angular_velocity",
                ));
            }
            if !r {
                if angular_velocity.is_some() {
                    return Err((
                        "angular_velocity",
                        "a body with rotates = false does not turn: remove angular_velocity or rotates",
                    ));
                }
                self = self.without_rotation();
            }
        }
        if let Some(v) = angular_velocity {
            let ok = v.iter().all(|x| x.is_finite()) && v.len() == if dim == 3 { 3 } else { 1 };
            if !ok {
                return Err((
                    "angular_velocity",
                    if dim == 3 {
                        "expected [wx, wy, wz], finite, in rad/s"
                    } else {
                        "a plate body turns about z: expected [wz], finite, in rad/s"
                    },
                ));
            }
            let w = if dim == 3 {
                [v[0], v[1], v[2]]
            } else {
                [0.0, 0.0, v[0]]
            };
            self = self.with_spin(w, dim);
        }
        Ok(self)
    }

    /// Centre of mass at the current time (the reference point for kinematic bodies).
    pub fn center(&self) -> [f64; 3] {
        match &self.inertia {
            Some(i) => add(self.position, rotate(self.orientation, i.center)),
            None => self.position,
        }
    }

    /// Kinetic energy from the half-step velocities (J), translation and rotation
    /// (`1/2 w . L`); zero for kinematic bodies.
    pub fn kinetic(&self) -> f64 {
        match self.motion {
            Motion::Dynamic { mass } => {
                0.5 * mass * self.velocity.iter().map(|v| v * v).sum::<f64>()
                    + 0.5 * dot(self.spin, self.angular_momentum)
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

    /// Angular momentum about the world origin (kg m^2/s): `X_c x M V + L`; zero for kinematic
    /// bodies.
    pub fn angular_momentum_about_origin(&self) -> [f64; 3] {
        match self.motion {
            Motion::Dynamic { .. } => {
                add(cross(self.center(), self.momentum()), self.angular_momentum)
            }
            Motion::Kinematic(_) => [0.0; 3],
        }
    }

    /// Velocity of the body's material point at `x` (m/s, half step): `V + w x (x - X_c)`.
    pub fn velocity_at(&self, x: [f64; 3]) -> [f64; 3] {
        if self.spin == [0.0; 3] {
            return self.velocity;
        }
        add(self.velocity, cross(self.spin, sub(x, self.center())))
    }

    /// Signed distance of `p` from the surface of the body as placed now, and the outward
    /// normal (see [`Geometry::signed_distance`]).
    pub fn signed_distance(&self, p: [f64; 3]) -> Option<(f64, [f64; 3])> {
        if self.orientation == IDENTITY {
            return self.geometry.signed_distance(self.position, p);
        }
        let local = rotate(conj(self.orientation), sub(p, self.position));
        let (d, n) = self.geometry.signed_distance([0.0; 3], local)?;
        Some((d, rotate(self.orientation, n)))
    }

    /// Axis-aligned bounds of the body as placed now (a turned body: the bounds of its turned
    /// local box, which contain it).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        if self.orientation == IDENTITY {
            return self.geometry.bounds(self.position);
        }
        let (lo, hi) = self.geometry.bounds([0.0; 3]);
        let r = matrix(self.orientation);
        // Each world axis spans the local box's centre and half-widths turned onto it. An
        // axis the turn does not mix in counts for nothing: a plate's shape is unbounded along
        // z, and turning about z leaves x and y bounded (2D bodies turn about z only). Where an
        // unbounded local axis is mixed in (a kinematic half-space that spins) the world axis
        // is unbounded too.
        let (mut wlo, mut whi) = ([0.0; 3], [0.0; 3]);
        for row in 0..3 {
            let (mut c, mut ext) = (self.position[row], 0.0);
            for k in 0..3 {
                let m = r[row][k];
                if m == 0.0 {
                    continue;
                }
                if !(lo[k].is_finite() && hi[k].is_finite()) {
                    (c, ext) = (0.0, f64::INFINITY);
                    break;
                }
                c += m * 0.5 * (lo[k] + hi[k]);
                ext += m.abs() * 0.5 * (hi[k] - lo[k]);
            }
            (wlo[row], whi[row]) = (c - ext, c + ext);
        }
        (wlo, whi)
    }

    /// The surface to draw (see [`Geometry::surface`]), placed and turned.
    #[allow(clippy::type_complexity)]
    pub fn surface(&self, size: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>, Vec<[u32; 2]>) {
        if self.orientation == IDENTITY {
            return self.geometry.surface(self.position, size);
        }
        let (pts, tris, lines) = self.geometry.surface([0.0; 3], size);
        let pts = pts
            .into_iter()
            .map(|p| add(self.position, rotate(self.orientation, p)))
            .collect();
        (pts, tris, lines)
    }

    /// How far any point within `radius` of the reference point has moved through turning since
    /// the orientation `from` (m): a bound for the contact lists' skin.
    pub fn turned_since(&self, from: [f64; 4], radius: f64) -> f64 {
        if self.orientation == from {
            return 0.0;
        }
        // |R x - R0 x| <= |R R0^-1 - 1| |x| = 2 sin(theta/2) |x|, theta the relative angle.
        let rel = mul(self.orientation, conj(from));
        let s = (rel[1] * rel[1] + rel[2] * rel[2] + rel[3] * rel[3]).sqrt();
        2.0 * s.min(1.0) * radius
    }

    /// Advance by one step under the reaction `r` (N) and the torque `tau` (N m, about the
    /// centre of mass): leapfrog for translation and rotation (module docs); kinematic bodies
    /// take their prescribed velocity at `t + dt/2` and turn at their constant spin.
    pub fn advance(&mut self, r: [f64; 3], tau: [f64; 3], t: f64, dt: f64, dim: usize) {
        self.reaction = r;
        self.torque = tau;
        let center = self.inertia.map(|i| i.center);
        // The centre of mass before the step (dynamic bodies turning about it).
        let xc = center.map(|c| add(self.position, rotate(self.orientation, c)));
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
        if let Some(inertia) = self.inertia {
            for c in 0..3 {
                if dim == 3 || c == 2 {
                    self.angular_momentum[c] += dt * tau[c];
                }
            }
            self.spin = self.midpoint_spin(&inertia, dt);
        }
        let turning = self.spin != [0.0; 3];
        if turning {
            self.orientation = normalize(mul(exp(scale(self.spin, dt)), self.orientation));
        }
        match (xc, center) {
            (Some(xc), Some(c)) if turning => {
                let xc1 = [0, 1, 2].map(|k| {
                    if k < dim {
                        xc[k] + dt * self.velocity[k]
                    } else {
                        xc[k]
                    }
                });
                self.position = sub(xc1, rotate(self.orientation, c));
                if dim == 2 {
                    self.position[2] = 0.0;
                }
            }
            _ => {
                for c in 0..dim {
                    self.position[c] += dt * self.velocity[c];
                }
            }
        }
    }

    /// `w = R_m I_0^-1 R_m^T L` at the midpoint orientation `R_m = exp(dt w / 2) R(t)`, found
    /// by fixed-point iteration (exact at once for bodies with isotropic inertia).
    fn midpoint_spin(&self, inertia: &Inertia, dt: f64) -> [f64; 3] {
        let l = self.angular_momentum;
        if l == [0.0; 3] {
            return [0.0; 3];
        }
        let mut w = mat_vec(&world(&inertia.inverse, self.orientation), l);
        for _ in 0..4 {
            let rm = mul(exp(scale(w, 0.5 * dt)), self.orientation);
            let next = mat_vec(&world(&inertia.inverse, rm), l);
            let change = norm(sub(next, w));
            w = next;
            if change <= 1e-15 * norm(w) {
                break;
            }
        }
        w
    }
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|x| x * s)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// `a x b`.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Quaternion product `a b` (w, x, y, z).
fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

fn conj(q: [f64; 4]) -> [f64; 4] {
    [q[0], -q[1], -q[2], -q[3]]
}

fn normalize(q: [f64; 4]) -> [f64; 4] {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    q.map(|x| x / n)
}

/// The rotation by the vector `v` (axis times angle, rad).
fn exp(v: [f64; 3]) -> [f64; 4] {
    let theta = norm(v);
    if theta == 0.0 {
        return IDENTITY;
    }
    let (s, c) = (0.5 * theta).sin_cos();
    let k = s / theta;
    [c, v[0] * k, v[1] * k, v[2] * k]
}

/// `q v q*`: `v` turned by `q`.
pub fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    mat_vec(&matrix(q), v)
}

/// The rotation matrix of the unit quaternion `q`.
fn matrix(q: [f64; 4]) -> [[f64; 3]; 3] {
    let [w, x, y, z] = q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

fn mat_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

/// `R A R^T` for the rotation `q`.
fn world(a: &[[f64; 3]; 3], q: [f64; 4]) -> [[f64; 3]; 3] {
    let r = matrix(q);
    let mut out = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let mut s = 0.0;
            for k in 0..3 {
                for l in 0..3 {
                    s += r[i][k] * a[k][l] * r[j][l];
                }
            }
            out[i][j] = s;
        }
    }
    out
}
